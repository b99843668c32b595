#!/usr/bin/env node
// three_load.mjs FILE... — loads each .glb with three.js's GLTFLoader (the
// loader of the three.js editor and of most web viewers, which ignores
// MSFT_lod; with meshoptimizer's decoder for EXT_meshopt_compression) and
// prints one JSON line per file: the scene's node names (and,
// in `children`, each one's child nodes with their meshes and textured
// materials: a LOD group's levels), the meshes and triangles it would draw, how many of their materials carry a
// base-colour texture, alpha test cutoffs, and the drawn bounding box. Exit
// status 1 when a file does not load. Node has no image decoder: textures
// are resolved to placeholders (the Khronos validator checks the images);
// what is checked here is that three.js builds the scene, with its
// materials and texture references, from the file.
import fs from 'node:fs';
import * as THREE from 'three';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';
import { MeshoptDecoder } from 'three/examples/jsm/libs/meshopt_decoder.module.js';

globalThis.self = globalThis; // GLTFLoader reads self.URL (Node has URL.createObjectURL)
THREE.TextureLoader.prototype.load = function (url, onLoad) {
    const t = new THREE.Texture();
    t.image = { width: 1, height: 1, src: url };
    if (onLoad) setTimeout(() => onLoad(t), 0);
    return t;
};

function summary(file, gltf) {
    const out = { file, nodes: [], meshes: 0, triangles: 0, textured: 0, cutoffs: [] };
    gltf.scene.children.forEach((c) => out.nodes.push(c.name));
    // a LOD group (lods.glb): each child of a top-level node, with what it draws
    out.children = gltf.scene.children.map((c) =>
        c.children.map((k) => {
            const o = { name: k.name, meshes: 0, textured: 0, visible: k.visible };
            k.traverse((m) => {
                if (!m.isMesh) return;
                o.meshes++;
                const mats = Array.isArray(m.material) ? m.material : [m.material];
                o.textured += mats.filter((x) => x.map).length;
            });
            return o;
        }));
    gltf.scene.updateMatrixWorld(true);
    const box = new THREE.Box3();
    gltf.scene.traverse((o) => {
        if (!o.isMesh) return;
        out.meshes++;
        const g = o.geometry;
        out.triangles += (g.index ? g.index.count : g.attributes.position.count) / 3;
        const mats = Array.isArray(o.material) ? o.material : [o.material];
        for (const m of mats) {
            if (m.map) out.textured++;
            if (m.alphaTest > 0) out.cutoffs.push(m.alphaTest);
        }
        box.expandByObject(o);
    });
    out.box = [box.min.toArray(), box.max.toArray()];
    return out;
}

let failed = 0;
for (const file of process.argv.slice(2)) {
    const b = fs.readFileSync(file);
    const ab = b.buffer.slice(b.byteOffset, b.byteOffset + b.byteLength);
    try {
        // output.compress "meshopt" files need the decoder (as a web page does)
        const gltf = await new GLTFLoader().setMeshoptDecoder(MeshoptDecoder).parseAsync(ab, '');
        console.log(JSON.stringify(summary(file, gltf)));
    } catch (e) {
        console.log(JSON.stringify({ file, error: String(e && e.message ? e.message : e) }));
        failed = 1;
    }
}
process.exit(failed);
