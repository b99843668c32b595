// viewer.js — sylvad's bake viewer (GET /v1/bakes/{key}/view; docs/runtime.md).
//
// Loads a finished bake's report.json, planes.json and impostor.json (when the
// bake has octahedral levels), the original as uploaded (GET .../inputs) and
// every level of the chain, and draws them unlit (the albedo the evaluator
// compares) with three.js: mesh levels from their lod<i>_<name>.glb, slicing
// levels through slicing.*.glsl, octahedral levels through octahedral.*.glsl,
// and (on request) stochastic levels as the full mesh through stochastic.*.glsl.
// One colour pipeline for every panel, glTF's: base-colour textures are sRGB
// (decoded by the sampler before filtering), factors linear, the output
// encoded to sRGB once (three.js's own materials; our shaders with
// SV_SRGB_OUTPUT); alpha modes as GLTFLoader sets them (BLEND blends, MASK
// tests its cutoff).
//
// Test mode (tests/integration/viewer_page.sh): ?test=1&lod=NAME|original
// &dir=X,Y,Z&size=S draws that one level into an S x S canvas, orthographic,
// framing report.json's evaluation.frame sphere as sylva's evaluator does
// (sv_eval_camera), on a transparent background; &mip=M picks an impostor mip
// (default 0). window.sylvaViewer reports progress: {ready, error, panels:
// [{name, covered, pixels}]}; in test mode its draw(NAME, [x,y,z], S, {fade})
// draws another view on the same page (levels load once) and returns its
// alpha, a PNG and the mean linear luminance of the covered pixels.
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { MeshoptDecoder } from 'three/addons/libs/meshopt_decoder.module.js';
import { OBJLoader } from 'three/addons/loaders/OBJLoader.js';
import { MTLLoader } from 'three/addons/loaders/MTLLoader.js';
import { PLYLoader } from 'three/addons/loaders/PLYLoader.js';
import { FBXLoader } from 'three/addons/loaders/FBXLoader.js';
import { ColladaLoader } from 'three/addons/loaders/ColladaLoader.js';

const state = (window.sylvaViewer = { ready: false, error: null, panels: [], lods: [] });
const params = new URLSearchParams(location.search);
const testMode = params.get('test') === '1';
const path = location.pathname.split('/');
const key = path[path.length - 2];
const bakeBase = new URL('./', location.href);              // .../v1/bakes/KEY/
const viewerBase = new URL('../../viewer/', location.href); // .../v1/viewer/
const art = (name) => new URL('artifacts/' + encodeURIComponent(name), bakeBase).href;
const inputsBase = new URL('inputs/', bakeBase).href;

const statusEl = document.getElementById('status');
function fail(err) {
    state.error = String(err && err.message ? err.message : err);
    statusEl.textContent = state.error;
    statusEl.className = 'error';
    console.error(err);
}

async function getJSON(url, optional) {
    const r = await fetch(url);
    if (optional && r.status === 404) return null;
    if (!r.ok) {
        let msg = r.statusText;
        try { msg = (await r.json()).error.message; } catch (e) { /* not a JSON error */ }
        throw new Error(`${url}: ${r.status} ${msg}`);
    }
    return r.json();
}
async function getText(url) {
    const r = await fetch(url);
    if (!r.ok) throw new Error(`${url}: ${r.status}`);
    return r.text();
}

// ---- geometry of views --------------------------------------------------

const V3 = THREE.Vector3;

// report.json input.origin: where the bake's local frame is in the file
// (docs/outputs.md, "Origin"); the page draws in the local frame, so the
// original is moved by -origin and each level's node translation undone
// ([0, 0, 0] for a tree modelled near the origin; absent in older bakes)
function localOffset(report) {
    const o = report.input && report.input.origin;
    return o ? new V3(-o[0], -o[1], -o[2]) : new V3();
}

// the sphere every evaluation view frames: report.json evaluation.frame, or
// (bakes written before it existed) the input's bounding sphere, which is
// what the evaluator framed (sv_mesh_sphere: AABB centre, half diagonal)
function frameSphere(report) {
    const f = report.evaluation && report.evaluation.frame;
    if (f) return { centre: new V3(...f.centre), radius: f.radius };
    const b = report.input.bounds;
    const c = new V3().addVectors(new V3(...b.min), new V3(...b.max)).multiplyScalar(0.5);
    return { centre: c, radius: b.radius };
}

// sv_eval_camera: orthographic, image height = 2r, up as close to +Y as
// possible (-Z when looking straight down, +Z straight up), clip ±2r
function evalCamera(sphere, dir) {
    const d = dir.clone().normalize();
    const ref = Math.abs(d.y) > 0.999 ? new V3(0, 0, d.y > 0 ? -1 : 1) : new V3(0, 1, 0);
    const right = new V3().crossVectors(ref, d).normalize();
    const up = new V3().crossVectors(d, right).normalize();
    const r = sphere.radius;
    const cam = new THREE.OrthographicCamera(-r, r, r, -r, 2 * r, 6 * r);
    cam.position.copy(sphere.centre).addScaledVector(d, 4 * r);
    cam.up.copy(up);
    cam.lookAt(sphere.centre);
    cam.updateMatrixWorld();
    return cam;
}

function dirFromAngles(azDeg, elDeg) {
    const az = THREE.MathUtils.degToRad(azDeg), el = THREE.MathUtils.degToRad(elDeg);
    return new V3(Math.cos(el) * Math.sin(az), Math.sin(el), Math.cos(el) * Math.cos(az));
}

// ---- materials ----------------------------------------------------------

// the evaluator compares unlit albedo: every material becomes a
// MeshBasicMaterial with the same texture (its colour space as the loader set
// it: sRGB for a base colour), colour (linear), alpha mode (GLTFLoader's
// transparent, depthWrite, opacity and alphaTest: BLEND blends, MASK tests
// its cutoff) and sides, and textures are sampled as sylva's renderer samples
// them, bilinear without mipmaps (core/render/render_osmesa.c: mipmaps
// average alpha and erode alpha-tested leaves; each level's atlas is sized
// for where it is drawn). `objRules`: the original is not glTF, and gets
// sylva's import rules instead (docs/design.md): a texture means alpha MASK
// with cutoff 0.5 (opaque textures pass the test anyway), double-sided.
function toUnlit(root, objRules) {
    root.traverse((o) => {
        if (!o.isMesh && !o.isPoints) return;
        const conv = (m) => {
            if (m.isShaderMaterial) return m;
            const b = new THREE.MeshBasicMaterial({
                map: m.map || null,
                color: m.color ? m.color.clone() : 0xffffff,
                alphaTest: m.alphaTest || 0,
                transparent: !!m.transparent,
                opacity: m.opacity ?? 1,
                depthWrite: m.depthWrite ?? true,
                side: m.side,
                vertexColors: !!m.vertexColors,
            });
            if (b.map) {
                b.map.generateMipmaps = false;
                b.map.minFilter = THREE.LinearFilter;
                b.map.needsUpdate = true;
            }
            if (objRules && b.map) {
                b.alphaTest = Math.max(b.alphaTest, 0.5);
                b.transparent = false;
                b.depthWrite = true;
            }
            if (objRules) b.side = THREE.DoubleSide;
            b.name = m.name;
            return b;
        };
        o.material = Array.isArray(o.material) ? o.material.map(conv) : conv(o.material);
    });
}

const shaderText = {};
async function loadShaders() {
    const names = ['octahedral.vert', 'octahedral.frag', 'slicing.vert', 'slicing.frag',
        'stochastic.vert', 'stochastic.frag'];
    await Promise.all(names.map(async (n) => {
        shaderText[n] = await getText(new URL(n + '.glsl', viewerBase).href);
    }));
}
// our shaders work in linear colour and, like three.js's own materials
// drawing to the canvas, encode their output to sRGB (SV_SRGB_OUTPUT)
function rawMaterial(name, defines, uniforms, extra) {
    return new THREE.RawShaderMaterial(Object.assign({
        glslVersion: THREE.GLSL3,
        vertexShader: shaderText[name + '.vert'],
        fragmentShader: shaderText[name + '.frag'],
        defines: Object.assign({ SV_SRGB_OUTPUT: '' }, defines || {}),
        uniforms,
        side: THREE.DoubleSide,
    }, extra || {}));
}

// a texture sampled by our own shaders: colour (srgb true) decoded from sRGB
// by the sampler before filtering, as glTF defines base colour and sylva's
// renderer and evaluator sample it; data (normals, depth) as stored; row 0
// at v = 0, no mipmaps
function shaderTexture(tex, srgb) {
    tex.colorSpace = srgb ? THREE.SRGBColorSpace : THREE.NoColorSpace;
    tex.flipY = false;
    tex.generateMipmaps = false;
    tex.minFilter = THREE.LinearFilter;
    tex.magFilter = THREE.LinearFilter;
    tex.wrapS = tex.wrapT = THREE.ClampToEdgeWrapping;
    tex.needsUpdate = true;
    return tex;
}

// ---- levels -------------------------------------------------------------

// output.compress "meshopt" files (EXT_meshopt_compression) need the decoder
const gltfLoader = new GLTFLoader().setMeshoptDecoder(MeshoptDecoder);
const texLoader = new THREE.TextureLoader();

// An octahedral level: one quad whose vertex shader turns it to the viewer.
async function makeImpostor(entry, light) {
    const mips = entry.mips && entry.mips.length ? entry.mips : [entry.maps.albedo];
    const albedo = await Promise.all(mips.map((m) => texLoader.loadAsync(art(m)).then((t) => shaderTexture(t, true))));
    const defines = {};
    const uniforms = {
        uOrtho: { value: true },
        uAlbedo: { value: albedo[0] },
        uGrid: { value: entry.grid },
        uHemi: { value: !!entry.hemi },
        uElevScale: { value: entry.elevation_scale ?? 1.0 },
        uFramePixels: { value: entry.frame_pixels },
        uMip: { value: 0 },
        uCentre: { value: new V3(...entry.centre) },
        uHalf: { value: entry.half },
        uBillboardHalf: { value: entry.billboard_half },
        uAlphaCutoff: { value: entry.alpha_cutoff ?? 0.5 },
    };
    if (light && entry.maps.normal) {
        defines.SV_OCTA_NORMAL = '';
        uniforms.uNormal = { value: shaderTexture(await texLoader.loadAsync(art(entry.maps.normal)), false) };
        uniforms.uLightDir = { value: new V3(0.4, 0.8, 0.45).normalize() };
        uniforms.uAmbient = { value: 0.35 };
    }
    if (entry.maps.depth) {
        // 16 bits: a browser decodes a 16-bit PNG to 8 bits, a parallax
        // error of half/128; the page decodes it itself into RG8 (high, low)
        defines.SV_OCTA_DEPTH = '';
        defines.SV_OCTA_DEPTH_RG8 = '';
        uniforms.uDepth = { value: await loadGray16(art(entry.maps.depth)) };
    }
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.Float32BufferAttribute(new Float32Array(12), 3));
    g.setIndex([0, 1, 2, 0, 2, 3]); // sylva's quad: corners (-u,-v) (+u,-v) (+u,+v) (-u,+v)
    const mat = rawMaterial('octahedral', defines, uniforms);
    const mesh = new THREE.Mesh(g, mat);
    mesh.frustumCulled = false; // its positions are made in the vertex shader
    const group = new THREE.Group();
    group.add(mesh);
    // before each draw: the camera kind, and the mip whose texels are
    // closest to one per pixel (test mode: the mip asked for, default 0)
    group.userData.prepare = (camera, pixelWorld) => {
        uniforms.uOrtho.value = !!camera.isOrthographicCamera;
        let m = 0;
        if (params.has('mip')) m = Number(params.get('mip')) | 0;
        else if (!testMode && pixelWorld > 0) {
            const texelWorld = (2 * entry.half) / entry.frame_pixels;
            m = Math.floor(Math.log2(Math.max(pixelWorld / texelWorld, 1)));
        }
        m = Math.min(Math.max(m, 0), albedo.length - 1);
        uniforms.uMip.value = m;
        uniforms.uAlbedo.value = albedo[m];
    };
    return group;
}

// A slicing level: its glb, the atlas primitive drawn through slicing.*.glsl
// with a per-vertex slicing index from planes.json.
function makeSlicing(root, planesLod, sphere) {
    const s = planesLod.slicing;
    let atlasMesh = null;
    root.traverse((o) => {
        if (o.isMesh && o.material && /^sylva_atlas/.test(o.material.name || '')) atlasMesh = o;
    });
    if (!atlasMesh) throw new Error(`slicing level ${planesLod.name}: no atlas primitive in ${planesLod.file}`);
    let geo = atlasMesh.geometry;
    const quads = planesLod.quads;
    const assign = (g) => {
        const n = g.attributes.position.count, group = new Float32Array(n).fill(-1);
        const idx = g.index ? g.index.array : null;
        for (let q = 0; q < quads.length; q++)
            for (let k = 0; k < 6; k++) {
                const v = idx ? idx[6 * q + k] : 6 * q + k;
                if (group[v] >= 0 && group[v] !== quads[q].group) return null; // shared vertex
                group[v] = quads[q].group;
            }
        return group;
    };
    let group = assign(geo);
    if (!group) {
        geo = geo.toNonIndexed();
        group = assign(geo);
    }
    geo.setAttribute('slicing', new THREE.Float32BufferAttribute(group, 1));
    const map = atlasMesh.material.map;
    if (map) shaderTexture(map, true);
    const uniforms = {
        uOrtho: { value: true },
        uCentre: { value: sphere.centre.clone() },
        uSlicings: { value: s.azimuthal_slicings },
        uStepDeg: { value: s.azimuth_step_deg },
        uTop: { value: !!s.top },
        uAlbedo: { value: map || whiteTexture() },
        uAlphaCutoff: { value: atlasMesh.material.alphaTest || 0.5 },
    };
    atlasMesh.geometry = geo;
    atlasMesh.material = rawMaterial('slicing', {}, uniforms);
    root.userData.prepare = (camera) => { uniforms.uOrtho.value = !!camera.isOrthographicCamera; };
}

// A 16-bit grayscale PNG (sylva's depth maps) as an RG8 texture, R = high
// byte, G = low byte: bilinear filtering is linear, so the shader's
// R * 65280 + G * 255 is the filtered 16-bit value.
async function loadGray16(url) {
    const r = await fetch(url);
    if (!r.ok) throw new Error(`${url}: ${r.status}`);
    const b = new Uint8Array(await r.arrayBuffer());
    const dv = new DataView(b.buffer);
    let off = 8, w = 0, h = 0;
    const idat = [];
    while (off + 8 <= b.length) {
        const len = dv.getUint32(off), type = String.fromCharCode(...b.subarray(off + 4, off + 8));
        if (type === 'IHDR') {
            w = dv.getUint32(off + 8);
            h = dv.getUint32(off + 12);
            if (b[off + 16] !== 16 || b[off + 17] !== 0 || b[off + 20] !== 0)
                throw new Error(`${url}: not a non-interlaced 16-bit gray PNG`);
        } else if (type === 'IDAT') idat.push(b.subarray(off + 8, off + 8 + len));
        else if (type === 'IEND') break;
        off += 12 + len;
    }
    const z = new Blob(idat).stream().pipeThrough(new DecompressionStream('deflate'));
    const raw = new Uint8Array(await new Response(z).arrayBuffer());
    const stride = 2 * w, bpp = 2, out = new Uint8Array(h * stride);
    for (let y = 0; y < h; y++) {
        const f = raw[y * (stride + 1)], src = y * (stride + 1) + 1, row = y * stride, prev = row - stride;
        for (let x = 0; x < stride; x++) {
            const a = x >= bpp ? out[row + x - bpp] : 0, up = y ? out[prev + x] : 0;
            const c = y && x >= bpp ? out[prev + x - bpp] : 0;
            let v = raw[src + x];
            if (f === 1) v += a;
            else if (f === 2) v += up;
            else if (f === 3) v += (a + up) >> 1;
            else if (f === 4) {
                const p = a + up - c, pa = Math.abs(p - a), pb = Math.abs(p - up), pc = Math.abs(p - c);
                v += pa <= pb && pa <= pc ? a : pb <= pc ? up : c;
            }
            out[row + x] = v & 255;
        }
    }
    // PNG is big-endian: each sample is already (high, low)
    const tex = new THREE.DataTexture(out, w, h, THREE.RGFormat, THREE.UnsignedByteType);
    return shaderTexture(tex, false);
}

let white = null;
function whiteTexture() {
    if (!white) {
        white = new THREE.DataTexture(new Uint8Array([255, 255, 255, 255]), 1, 1);
        white.colorSpace = THREE.SRGBColorSpace;
        white.needsUpdate = true;
    }
    return white;
}

// The full level drawn as the prefix mu of its leaves (stochastic.*.glsl).
function makeStochasticFade(fullScene, report) {
    const root = fullScene.clone(true);
    let extras = null;
    root.traverse((o) => { if (o.userData && o.userData.sylva_stochastic) extras = o.userData.sylva_stochastic; });
    const uniformsList = [];
    root.traverse((o) => {
        if (!o.isMesh || !o.geometry.attributes._leaf_order) return;
        const order = o.geometry.attributes._leaf_order.array;
        if (!order.some((x) => x > 0)) return; // trunk: its own material
        const m = o.material;
        const map = m.map ? shaderTexture(m.map.clone(), true) : whiteTexture();
        const u = {
            uMu: { value: 1 }, uFade: { value: extras ? extras.fade_radius : 0.1 },
            uAreaScale: { value: 1 }, uAreaGamma: { value: extras ? extras.area_gamma : 1 },
            uAlbedo: { value: map },
            uBaseColor: { value: new THREE.Vector4(m.color ? m.color.r : 1, m.color ? m.color.g : 1, m.color ? m.color.b : 1, m.opacity ?? 1) },
            uAlphaCutoff: { value: m.alphaTest || 0.5 },
        };
        uniformsList.push(u);
        o.material = rawMaterial('stochastic', {}, u);
    });
    const r = extras ? extras.visible_ratio : 0;
    root.userData.setMu = (mu) => {
        mu = Math.min(Math.max(mu, 1e-6), 1);
        // s = (1 - (1 - r)^(1/mu)) / r, exact for small r (docs/methods/stochastic.md)
        const s = r > 0 ? -Math.expm1(Math.log1p(-r) / mu) / r : 1 / mu;
        for (const u of uniformsList) { u.uMu.value = mu; u.uAreaScale.value = s; }
    };
    // Cook's schedule: lambda = b^log_h(1/2), b = d0^2 / d^2 (d0 = the scene's nearest distance when 0)
    root.userData.muAt = (d) => {
        const h = extras ? extras.h : 0.5;
        const d0 = extras && extras.d0 > 0 ? extras.d0 : report.scene.distance[0];
        const b = Math.min(1, (d0 * d0) / (d * d));
        return Math.pow(b, Math.log(0.5) / Math.log(h));
    };
    return root;
}

// ---- the original -------------------------------------------------------

async function loadOriginal(report) {
    const list = await getJSON(new URL('inputs', bakeBase).href);
    const mesh = list.mesh;
    const ext = mesh.toLowerCase().split('.').pop();
    // sylva serves uploaded files by base name only: map every URL a loader
    // asks for below inputs/ (a texture in a sub-folder, say) to its base name
    const manager = trackedManager();
    manager.setURLModifier((u) => {
        if (!u.startsWith(inputsBase)) return u;
        const name = decodeURIComponent(u.slice(inputsBase.length)).split(/[\\/]/).pop();
        return inputsBase + encodeURIComponent(name);
    });
    const url = inputsBase + encodeURIComponent(mesh);
    let obj;
    if (ext === 'glb' || ext === 'gltf') {
        obj = (await new GLTFLoader(manager).setMeshoptDecoder(MeshoptDecoder).loadAsync(url)).scene;
    } else if (ext === 'obj') {
        // without its line elements (`l`): OBJLoader turns an object with
        // any line into lines only, where sylva's import keeps its faces and
        // ignores the lines (the Scopia bush's stems)
        const text = (await getText(url)).replace(/^[ \t]*l[ \t].*$/gm, '');
        const loader = new OBJLoader(manager);
        const libs = [...text.matchAll(/^\s*mtllib\s+(.+?)\s*$/gm)].map((m) => m[1]);
        for (const lib of libs) {
            const name = lib.split(/[\\/]/).pop();
            if (!list.files.some((f) => f.name === name)) continue;
            const mtl = new MTLLoader(manager).setResourcePath(inputsBase)
                .parse(await getText(inputsBase + encodeURIComponent(name)), inputsBase);
            mtl.preload();
            // Kd as sylva reads it: linear, the glTF factor as is
            // (docs/outputs.md "Colour"); MTLLoader takes it as sRGB
            for (const [name, info] of Object.entries(mtl.materialsInfo)) {
                const mat = mtl.materials[name];
                if (mat && mat.color && Array.isArray(info.kd)) mat.color.setRGB(info.kd[0], info.kd[1], info.kd[2]);
            }
            loader.setMaterials(mtl);
        }
        obj = loader.parse(text);
    } else if (ext === 'ply') {
        const geo = await new PLYLoader(manager).loadAsync(url);
        geo.computeVertexNormals();
        obj = new THREE.Mesh(geo, new THREE.MeshBasicMaterial({ vertexColors: !!geo.attributes.color }));
    } else if (ext === 'fbx') {
        obj = await new FBXLoader(manager).loadAsync(url);
    } else if (ext === 'dae') {
        obj = (await new ColladaLoader(manager).loadAsync(url)).scene;
    } else {
        throw new Error(`original ${mesh}: no three.js loader for .${ext}`);
    }
    await manager.idle(); // the textures the materials asked for
    toUnlit(obj, !(ext === 'glb' || ext === 'gltf')); // a glTF says its own alpha modes
    // into sylva's frame: the import's unit scale, then Z-up rotated to +Y
    // (sv_mesh_rotate_up: "Z": y' = z, z' = -y; "-Z": y' = -z, z' = y)
    const wrap = new THREE.Group();
    const inner = new THREE.Group();
    inner.add(obj);
    const s = report.input.unit_scale || 1;
    inner.scale.setScalar(s);
    const up = report.input.up;
    if (up === 'Z') wrap.rotation.x = -Math.PI / 2;
    else if (up === '-Z') wrap.rotation.x = Math.PI / 2;
    wrap.position.copy(localOffset(report)); // after the rotation: origin is in sylva's frame
    wrap.add(inner);
    return wrap;
}

// A LoadingManager that can say when everything it was handed has loaded
// (or failed): idle() resolves once as many items ended as started.
function trackedManager() {
    const m = new THREE.LoadingManager();
    let started = 0, ended = 0, wake = [];
    const start = m.itemStart.bind(m), end = m.itemEnd.bind(m);
    m.itemStart = (u) => { started++; start(u); };
    m.itemEnd = (u) => {
        ended++;
        end(u);
        if (ended >= started) { for (const w of wake) w(); wake = []; }
    };
    m.idle = () => new Promise((resolve) => { if (ended >= started) resolve(); else wake.push(resolve); });
    return m;
}

// ---- drawing ------------------------------------------------------------

const renderer = new THREE.WebGLRenderer({ antialias: false, alpha: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(1);
renderer.setClearColor(0x000000, 0);

const scenes = new Map();
function sceneOf(obj) {
    if (!scenes.has(obj)) {
        const s = new THREE.Scene();
        s.add(obj);
        scenes.set(obj, s);
    }
    return scenes.get(obj);
}

// draws obj with camera into a 2D canvas; returns its covered pixel count
function draw(canvas, obj, camera, pixelWorld) {
    const w = canvas.width, h = canvas.height;
    renderer.setSize(w, h, false);
    obj.traverse((o) => { if (o.userData.prepare) o.userData.prepare(camera, pixelWorld); });
    renderer.render(sceneOf(obj), camera);
    const ctx = canvas.getContext('2d', { willReadFrequently: true });
    ctx.clearRect(0, 0, w, h);
    ctx.drawImage(renderer.domElement, 0, 0);
    const px = ctx.getImageData(0, 0, w, h).data;
    let covered = 0;
    for (let i = 3; i < px.length; i += 4) if (px[i] > 0) covered++;
    return covered;
}

// mean linear luminance (Rec. 709) of the pixels the last draw covered
// (alpha > 0), from the sRGB bytes the shaders wrote (read from the WebGL
// buffer: the 2D canvas would divide colour by a MASK texel's alpha)
const linTable = Array.from({ length: 256 }, (_, i) => {
    const c = i / 255;
    return c <= 0.04045 ? c / 12.92 : Math.pow((c + 0.055) / 1.055, 2.4);
});
function meanLuminance(size) {
    const gl = renderer.getContext(), px = new Uint8Array(4 * size * size);
    gl.readPixels(0, 0, size, size, gl.RGBA, gl.UNSIGNED_BYTE, px);
    let sum = 0, n = 0;
    for (let i = 0; i < px.length; i += 4) {
        if (px[i + 3] === 0) continue;
        sum += 0.2126 * linTable[px[i]] + 0.7152 * linTable[px[i + 1]] + 0.0722 * linTable[px[i + 2]];
        n++;
    }
    return n ? sum / n : 0;
}

// ---- the page -----------------------------------------------------------

async function main() {
    document.getElementById('key').textContent = key;
    const status = await getJSON(new URL('../' + key, bakeBase).href);
    const listed = new Set(((status.manifest || {}).artifacts || []).map((a) => a.name));
    const [report, planes, impostor] = await Promise.all([
        getJSON(art('report.json')),
        getJSON(art('planes.json')),
        listed.has('impostor.json') ? getJSON(art('impostor.json')) : null,
        loadShaders(),
    ]);
    const sphere = frameSphere(report);
    const planesOf = new Map((planes.lods || []).map((l) => [l.name, l]));
    const impostorOf = new Map(((impostor && impostor.lods) || []).map((l) => [l.lod, l]));
    const light = params.get('light') === '1';
    const fade = params.get('fade') === '1';

    // a level's drawable: the impostor, or its glb (slicing: through the
    // slicing shader); with fade, a stochastic level below lambda = 1 is the
    // full level through the fade shader at the level's mu. Loaded once.
    const loaded = new Map();
    const loadLevel = (lod, withFade) => {
        const id = lod.name + (withFade ? '?fade' : '');
        if (!loaded.has(id)) loaded.set(id, (async () => {
            const pl = planesOf.get(lod.name) || {};
            const oct = impostorOf.get(lod.name);
            if (withFade && lod.source === 'stochastic' && lod.lambda !== 1) {
                const full = report.lods.find((l) => l.source === 'stochastic' && l.lambda === 1);
                if (full && report.lods.indexOf(full) === 0) {
                    // the fade attributes are in model.glb only (docs/outputs.md),
                    // whose scene is its finest level: the full one
                    const gltf = await gltfLoader.loadAsync(art('model.glb'));
                    gltf.scene.position.copy(localOffset(report));
                    toUnlit(gltf.scene, false);
                    const obj = makeStochasticFade(gltf.scene, report);
                    obj.userData.setMu(lod.leaf_fraction ?? lod.lambda);
                    return { kind: 'stochastic fade', obj };
                }
            }
            if (oct) return { kind: 'octahedral', obj: await makeImpostor(oct, light) };
            const gltf = await gltfLoader.loadAsync(art(lod.file || pl.file));
            gltf.scene.position.copy(localOffset(report)); // undoes the nodes' translation
            toUnlit(gltf.scene, false);
            if (pl.slicing) makeSlicing(gltf.scene, pl, sphere);
            return { kind: pl.slicing ? 'slicing' : 'mesh', obj: gltf.scene };
        })());
        return loaded.get(id);
    };
    let originalP = null;
    const loadOriginalOnce = () => (originalP = originalP || loadOriginal(report));

    if (testMode) {
        // draw(NAME, [x, y, z], S, {fade}): one level ('original' for the
        // original) from direction x,y,z with the evaluator's camera into the
        // S x S canvas#test; returns its alpha and a PNG of it
        document.body.classList.add('test');
        const canvas = document.createElement('canvas');
        canvas.id = 'test';
        document.body.appendChild(canvas);
        state.draw = async (name, dir, size, opts) => {
            const lod = report.lods.find((l) => l.name === name);
            if (name !== 'original' && !lod) throw new Error(`no level named ${name}`);
            const obj = name === 'original' ? await loadOriginalOnce()
                : (await loadLevel(lod, !!(opts && opts.fade))).obj;
            canvas.width = canvas.height = size;
            canvas.style.width = canvas.style.height = size + 'px';
            const cam = evalCamera(sphere, new V3(...dir));
            const covered = draw(canvas, obj, cam, (2 * sphere.radius) / size);
            const px = canvas.getContext('2d').getImageData(0, 0, size, size).data;
            const alpha = new Array(size * size);
            for (let i = 0; i < alpha.length; i++) alpha[i] = px[4 * i + 3];
            state.panels = [{ name, covered, pixels: size * size }];
            return { width: size, height: size, covered, alpha, luminance: meanLuminance(size),
                png: canvas.toDataURL('image/png') };
        };
        if (params.has('lod')) {
            const dir = (params.get('dir') || '0,0,1').split(',').map(Number);
            await state.draw(params.get('lod'), dir, Number(params.get('size')) || 256, { fade });
        }
        state.ready = true;
        return;
    }

    // the levels, in chain order
    const levels = [];
    for (const lod of report.lods) {
        const { kind, obj } = await loadLevel(lod, fade);
        levels.push({ name: lod.name, source: lod.source || '', switch_distance: lod.switch_distance, lod, kind, obj });
    }
    state.lods = levels.map((l) => ({ name: l.name, kind: l.kind, switch_distance: l.switch_distance }));
    const original = await loadOriginalOnce();

    // every level, orthographic from the chosen direction
    const levelsEl = document.getElementById('levels');
    const panels = [{ name: 'original', obj: original, caption: 'original' }].concat(levels.map((l, i) => ({
        name: l.name, obj: l.obj,
        caption: `${i}: ${l.name} (${l.kind}) · from ${l.switch_distance.toFixed(1)} m · ${l.lod.triangles} triangles`,
    })));
    for (const p of panels) {
        const fig = document.createElement('figure');
        p.canvas = document.createElement('canvas');
        p.canvas.width = p.canvas.height = 192;
        p.canvas.dataset.level = p.name;
        const cap = document.createElement('figcaption');
        cap.textContent = p.caption;
        fig.append(p.canvas, cap);
        levelsEl.appendChild(fig);
    }

    // the chain at a distance
    const dmin = report.scene.distance[0], dmax = report.scene.distance[1];
    const slider = document.getElementById('distance');
    const toDist = (t) => dmin * Math.pow(dmax / dmin, t / 1000);
    const toSlider = (d) => Math.round((1000 * Math.log(d / dmin)) / Math.log(dmax / dmin));
    const list = document.getElementById('switches');
    for (const l of levels) {
        const o = document.createElement('option');
        o.value = Math.min(1000, Math.max(0, toSlider(l.switch_distance)));
        list.appendChild(o);
    }
    document.getElementById('screen').textContent = report.scene.screen_height;
    // the level drawn at distance d: the coarsest whose switch distance is <= d
    state.lodAt = (d) => {
        let k = 0;
        levels.forEach((l, i) => { if (l.switch_distance <= d) k = i; });
        return levels[k];
    };

    const az = document.getElementById('azimuth'), el = document.getElementById('elevation');
    const magnify = document.getElementById('magnify');
    const chainOrig = document.getElementById('chain-original'), chainLod = document.getElementById('chain-lod');
    const direction = () => {
        document.getElementById('azimuth-out').textContent = az.value + '°';
        document.getElementById('elevation-out').textContent = el.value + '°';
        return dirFromAngles(Number(az.value), Number(el.value));
    };
    const redrawLevels = () => {
        const ortho = evalCamera(sphere, direction());
        state.panels = panels.map((p) => ({
            name: p.name,
            covered: p.obj ? draw(p.canvas, p.obj, ortho, (2 * sphere.radius) / p.canvas.width) : 0,
            pixels: p.canvas.width * p.canvas.height,
        }));
    };
    const redrawChain = () => {
        const dir = direction();
        const d = toDist(Number(slider.value));
        const lv = state.lodAt(d);
        if (lv.obj && lv.obj.userData.setMu) lv.obj.userData.setMu(lv.obj.userData.muAt(d));
        document.getElementById('distance-out').textContent = `${d.toFixed(1)} m`;
        document.getElementById('chain-lod-name').textContent = `${lv.name} (${lv.kind}), drawn from ${lv.switch_distance.toFixed(1)} m`;
        // perspective at distance d: the scene's fov over its screen height,
        // so the panel shows the tree at its real size in pixels
        const H = chainLod.height;
        const fovScene = THREE.MathUtils.degToRad(report.scene.fov_deg);
        let fov = 2 * Math.atan((Math.tan(fovScene / 2) * H) / report.scene.screen_height);
        if (magnify.checked) fov = 2 * Math.asin(Math.min(1, sphere.radius / d)) * 1.02;
        const cam = new THREE.PerspectiveCamera(THREE.MathUtils.radToDeg(fov), 1,
            Math.max(d - 2 * sphere.radius, d * 1e-3), d + 2 * sphere.radius);
        cam.position.copy(sphere.centre).addScaledVector(dir, d);
        cam.lookAt(sphere.centre);
        cam.updateMatrixWorld();
        const pixelWorld = (2 * d * Math.tan(fov / 2)) / H;
        state.chain = { distance: d, lod: lv.name };
        if (original) draw(chainOrig, original, cam, pixelWorld);
        if (lv.obj) draw(chainLod, lv.obj, cam, pixelWorld);
    };
    // for scripts: moves the slider to the first step at or past d, draws
    state.setDistance = (d) => {
        slider.value = Math.min(1000, Math.max(0, Math.ceil(toSlider(d) - 1e-6)));
        while (Number(slider.value) < 1000 && toDist(Number(slider.value)) < d * (1 - 1e-9))
            slider.value = Number(slider.value) + 1;
        redrawChain();
        return state.chain;
    };
    for (const e of [slider, magnify]) e.addEventListener('input', redrawChain);
    for (const e of [az, el]) e.addEventListener('input', () => { redrawLevels(); redrawChain(); });
    slider.value = 0;
    redrawLevels();
    redrawChain();
    statusEl.textContent = `${report.lods.length} levels; original: ${report.input.format}, ` +
        `${report.input.mesh ? report.input.mesh.triangles : '?'} triangles`;
    state.ready = true;
}

main().catch(fail);
