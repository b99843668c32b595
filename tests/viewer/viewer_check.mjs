#!/usr/bin/env node
// viewer_check.mjs — drives Debian's chromium (headless, through playwright-core)
// through sylvad's viewer page for tests/integration/viewer_page.sh.
//
//   node viewer_check.mjs BASE_URL KEY OUT_DIR [--compare LOD X,Y,Z SIZE REF.png]...
//
// 1. GET BASE_URL/v1/bakes/KEY/view: the page must load without an error and
//    draw covered pixels in every panel (the original and each level), and its
//    distance slider must walk the chain: at each level's switch distance the
//    page draws that level. A screenshot goes to OUT_DIR/view.png.
// 2. For each --compare: the page's test mode draws level LOD from direction
//    X,Y,Z at SIZE x SIZE (the evaluator's framing); its coverage (alpha > 0)
//    is compared with REF.png's (alpha >= 128; `sylva-bake view` of the same
//    view): IoU = |A ∩ B| / |A ∪ B|, printed, and must be >= 0.95. The page's
//    render goes to OUT_DIR/test_LOD.png. REF may also be page:OTHER, the
//    page's own test render of OTHER (a level or `original`) from the same view.
// 3. For each --blend LOD X,Y,Z SIZE (a level whose leaves are alpha BLEND,
//    the oak's): the page's test render of it must have transparent pixels
//    inside the crown: of the pixels between the first and the last covered
//    one of each row, at least 15 % with alpha < 128 (the oak's full level:
//    8.9 % with its leaf cards drawn as opaque squares, 21.3 % drawn as
//    three.js draws BLEND).
// 4. --luminance KEY2 SIZE: every level file (report.json lods[].file) of
//    bake KEY2 loaded by three.js's own GLTFLoader (with its meshopt decoder) and drawn unlit as loaded
//    (MeshBasicMaterial with the loader's map, colour, alpha mode and sides;
//    sRGB output) from four directions; the mean linear luminance
//    (Rec. 709) over covered pixels, summed over the views, must be within
//    7 % of the first level's (the full mesh), both with the mipmaps the
//    files ask for and without them: the quad levels look as bright as the
//    mesh levels in an engine (docs/outputs.md "Colour", "Textures").
// 5. --panels KEY2 X,Y,Z SIZE LOD...: the page's test renders of those
//    panels of bake KEY2 (a level, `original`, LEVEL?fade=1) from one view:
//    each one's mean linear luminance over its covered pixels within 7 % of
//    the first's (every panel under one colour pipeline).
// --on KEY2: the --compare and --blend options after it are of bake KEY2.
// Prints "ok - ..." / "FAIL - ..." lines; exits 1 on any failure.
import fs from 'node:fs';
import path from 'node:path';
import zlib from 'node:zlib';
import { chromium } from 'playwright-core';

const [base, key, outDir, ...rest] = process.argv.slice(2);
if (!base || !key || !outDir) {
    console.error('usage: viewer_check.mjs BASE_URL KEY OUT_DIR [--compare LOD X,Y,Z SIZE REF.png]...');
    process.exit(2);
}
const compares = [], blends = [], lums = [], panelSets = [];
let onKey = key;
for (let i = 0; i < rest.length; i++) {
    if (rest[i] === '--on' && i + 1 < rest.length) {
        onKey = rest[++i];
    } else if (rest[i] === '--compare' && i + 4 < rest.length) {
        compares.push({ key: onKey, lod: rest[i + 1], dir: rest[i + 2], size: Number(rest[i + 3]), ref: rest[i + 4] });
        i += 4;
    } else if (rest[i] === '--blend' && i + 3 < rest.length) {
        blends.push({ key: onKey, lod: rest[i + 1], dir: rest[i + 2], size: Number(rest[i + 3]) });
        i += 3;
    } else if (rest[i] === '--panels' && i + 4 < rest.length) {
        const [k, d, sz] = rest.slice(i + 1, i + 4);
        let j = i + 4;
        const names = [];
        while (j < rest.length && !rest[j].startsWith('--')) names.push(rest[j++]);
        panelSets.push({ key: k, dir: d, size: Number(sz), names });
        i = j - 1;
    } else if (rest[i] === '--luminance' && i + 2 < rest.length) {
        lums.push({ key: rest[i + 1], size: Number(rest[i + 2]) });
        i += 2;
    } else {
        console.error(`viewer_check.mjs: bad argument ${rest[i]}`);
        process.exit(2);
    }
}
let failures = 0;
const ok = (m) => console.log(`ok   - ${m}`);
const bad = (m) => { console.log(`FAIL - ${m}`); failures++; };

// A PNG's alpha channel (8-bit RGBA or gray+alpha, non-interlaced), for the
// reference renders: {width, height, alpha: Uint8Array}.
function pngAlpha(file) {
    const b = fs.readFileSync(file);
    if (b.readUInt32BE(0) !== 0x89504e47) throw new Error(`${file}: not a PNG`);
    let off = 8, w = 0, h = 0, depth = 0, ctype = 0, interlace = 0;
    const idat = [];
    while (off < b.length) {
        const len = b.readUInt32BE(off), type = b.toString('latin1', off + 4, off + 8);
        const data = b.subarray(off + 8, off + 8 + len);
        if (type === 'IHDR') {
            w = data.readUInt32BE(0); h = data.readUInt32BE(4);
            depth = data[8]; ctype = data[9]; interlace = data[12];
        } else if (type === 'IDAT') idat.push(data);
        else if (type === 'IEND') break;
        off += 12 + len;
    }
    const channels = { 6: 4, 4: 2 }[ctype];
    if (depth !== 8 || !channels || interlace) throw new Error(`${file}: want 8-bit RGBA or gray+alpha, non-interlaced`);
    const raw = zlib.inflateSync(Buffer.concat(idat));
    const stride = w * channels, out = Buffer.alloc(h * stride), alpha = new Uint8Array(w * h);
    for (let y = 0; y < h; y++) {
        const f = raw[y * (stride + 1)], src = raw.subarray(y * (stride + 1) + 1, (y + 1) * (stride + 1));
        const row = out.subarray(y * stride, (y + 1) * stride), prev = y ? out.subarray((y - 1) * stride, y * stride) : null;
        for (let x = 0; x < stride; x++) {
            const a = x >= channels ? row[x - channels] : 0, up = prev ? prev[x] : 0;
            const c = prev && x >= channels ? prev[x - channels] : 0;
            let v = src[x];
            if (f === 1) v += a;
            else if (f === 2) v += up;
            else if (f === 3) v += (a + up) >> 1;
            else if (f === 4) {
                const p = a + up - c, pa = Math.abs(p - a), pb = Math.abs(p - up), pc = Math.abs(p - c);
                v += pa <= pb && pa <= pc ? a : pb <= pc ? up : c;
            }
            row[x] = v & 255;
        }
        for (let x = 0; x < w; x++) alpha[y * w + x] = row[x * channels + channels - 1];
    }
    return { width: w, height: h, alpha };
}

async function waitReady(page, what) {
    try {
        await page.waitForFunction(() => window.sylvaViewer && (window.sylvaViewer.ready || window.sylvaViewer.error),
            null, { timeout: 30000 });
    } catch (e) {
        bad(`${what}: not ready after 30 s`);
        return null;
    }
    const st = await page.evaluate(() => window.sylvaViewer);
    if (st.error) { bad(`${what}: page error: ${st.error}`); return null; }
    ok(`${what}: page ready`);
    return st;
}

const browser = await chromium.launch({
    executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
    // WebGL2 on the CPU (SwiftShader): CI has no GPU
    args: ['--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist', '--no-sandbox'],
});
try {
    const page = await browser.newPage({ viewport: { width: 1400, height: 1000 }, deviceScaleFactor: 1 });
    const errors = [];
    page.on('pageerror', (e) => errors.push(String(e)));
    // three.js reports a shader that does not build on the console
    page.on('console', (m) => {
        if (m.type() === 'error' && !/^Failed to load resource/.test(m.text())) errors.push(m.text().slice(0, 300));
    });
    // every request the page makes must succeed (the browser's own favicon aside)
    page.on('response', (r) => {
        if (r.status() >= 400 && !r.url().endsWith('/favicon.ico')) errors.push(`${r.status()} ${r.url()}`);
    });
    await page.goto(`${base}/v1/bakes/${key}/view`);
    const st = await waitReady(page, 'view page');
    if (st) {
        for (const p of st.panels) {
            if (p.covered > 0 && p.covered < p.pixels) ok(`panel ${p.name}: ${p.covered} of ${p.pixels} pixels drawn`);
            else bad(`panel ${p.name}: ${p.covered} of ${p.pixels} pixels drawn (want some, not all)`);
        }
        console.log(`levels: ${st.lods.map((l) => `${l.name}=${l.kind}`).join(' ')}`);
        const names = st.panels.map((p) => p.name);
        if (names[0] === 'original' && names.length === st.lods.length + 1) ok(`panels: ${names.join(', ')}`);
        else bad(`panels ${names.join(', ')} are not the original and ${st.lods.length} levels`);
        // the slider walks the chain: at each switch distance, that level
        for (const l of st.lods) {
            const got = await page.evaluate((d) => window.sylvaViewer.setDistance(d), l.switch_distance);
            // the slider's step is 1/1000 of the range: at the first step past
            // the switch the level drawn is this one unless the next level
            // starts within that step
            const want = await page.evaluate((d) => window.sylvaViewer.lodAt(d).name, got.distance);
            if (got.lod === want && got.distance >= l.switch_distance * (1 - 1e-9))
                ok(`slider at ${got.distance.toFixed(1)} m (switch ${l.switch_distance.toFixed(1)} m) draws ${got.lod}`);
            else bad(`slider at ${got.distance.toFixed(1)} m draws ${got.lod}, want ${want} (switch of ${l.name}: ${l.switch_distance})`);
            if (got.lod !== l.name) console.log(`note - ${l.name}'s band is thinner than a slider step`);
        }
        const last = st.lods[st.lods.length - 1].name;
        const far = await page.evaluate(() => window.sylvaViewer.setDistance(Infinity).lod);
        if (far === last) ok(`slider at the far end draws the last level, ${last}`);
        else bad(`slider at the far end draws ${far}, want ${last}`);
        await page.evaluate(() => window.sylvaViewer.setDistance(0));
        await page.screenshot({ path: path.join(outDir, 'view.png'), fullPage: true });
    }
    // every shader pair compiles and links in WebGL2 with each set of its
    // #defines (docs/runtime.md), whether or not this bake uses it
    const combos = [['octahedral', []], ['octahedral', ['SV_OCTA_NORMAL']], ['octahedral', ['SV_OCTA_DEPTH']],
        ['octahedral', ['SV_OCTA_NORMAL', 'SV_OCTA_DEPTH']], ['octahedral', ['SV_OCTA_DEPTH', 'SV_OCTA_DEPTH_RG8']], ['slicing', []], ['slicing', ['SV_SLICING_BLEND']],
        ['stochastic', []], ['octahedral', ['SV_OCTA_NORMAL', 'SV_OCTA_DEPTH', 'SV_OCTA_DEPTH_RG8', 'SV_SRGB_OUTPUT']],
        ['slicing', ['SV_SLICING_BLEND', 'SV_SRGB_OUTPUT']], ['stochastic', ['SV_SRGB_OUTPUT']]];
    const logs = await page.evaluate(async (combos) => {
        const gl = document.createElement('canvas').getContext('webgl2');
        const src = async (n) => (await fetch(new URL(`../../viewer/${n}.glsl`, location.href))).text();
        const out = [];
        for (const [name, defs] of combos) {
            const head = '#version 300 es\n' + defs.map((d) => `#define ${d}\n`).join('');
            const prog = gl.createProgram();
            let log = '';
            for (const [type, stage] of [[gl.VERTEX_SHADER, 'vert'], [gl.FRAGMENT_SHADER, 'frag']]) {
                const sh = gl.createShader(type);
                gl.shaderSource(sh, head + await src(`${name}.${stage}`));
                gl.compileShader(sh);
                if (!gl.getShaderParameter(sh, gl.COMPILE_STATUS)) log += `${stage}: ${gl.getShaderInfoLog(sh)} `;
                gl.attachShader(prog, sh);
            }
            gl.linkProgram(prog);
            if (!log && !gl.getProgramParameter(prog, gl.LINK_STATUS)) log = `link: ${gl.getProgramInfoLog(prog)}`;
            out.push({ name: `${name}${defs.length ? ' + ' + defs.join(' + ') : ''}`, log });
        }
        return out;
    }, combos);
    for (const l of logs) {
        if (l.log) bad(`shader ${l.name} does not build: ${l.log}`);
        else ok(`shader ${l.name} compiles and links`);
    }
    if (errors.length) bad(`page errors: ${errors.join(' | ')}`);
    else ok('no page error, no failed request');

    // the page's test render of one level, all on one test-mode page per
    // bake (each level loads once): {width, height, alpha[], png, luminance}
    const testPages = new Map();
    const rendered = new Map(); // one render per (bake, spec, dir, size)
    const testRender = async (spec, dir, size, k) => {
        const id = `${k} ${spec} ${dir} ${size}`;
        if (!rendered.has(id)) rendered.set(id, testRenderOnce(spec, dir, size, k));
        return rendered.get(id);
    };
    const testRenderOnce = async (spec, dir, size, k) => {
        // (SPEC: a level, or a level with page parameters: stochastic50?fade=1)
        const [lod, extra] = spec.split('?');
        if (!testPages.has(k)) testPages.set(k, (async () => {
            const p = await browser.newPage({ viewport: { width: 600, height: 600 }, deviceScaleFactor: 1 });
            p.on('pageerror', (e) => bad(`test page: ${e}`));
            await p.goto(`${base}/v1/bakes/${k}/view?test=1`);
            return (await waitReady(p, `test-mode page of ${k.slice(0, 8)}`)) ? p : null;
        })());
        const testPage = await testPages.get(k);
        if (!testPage) return null;
        let shot;
        try {
            shot = await testPage.evaluate(([l, d, s, f]) => window.sylvaViewer.draw(l, d, s, { fade: f }),
                [lod, dir.split(',').map(Number), size, /(^|&)fade=1(&|$)/.test(extra || '')]);
        } catch (e) {
            bad(`test view of ${spec} from ${dir}: ${e.message.split('\n')[0]}`);
            return null;
        }
        fs.writeFileSync(path.join(outDir, `test_${k === key ? '' : k.slice(0, 8) + '_'}${spec.replace(/[^A-Za-z0-9_.-]/g, '_')}_${dir}.png`),
            Buffer.from(shot.png.split(',')[1], 'base64'));
        return shot;
    };
    for (const c of compares) {
        const shot = await testRender(c.lod, c.dir, c.size, c.key);
        if (!shot) continue;
        const fromPage = c.ref.startsWith('page:');
        const ref = fromPage ? await testRender(c.ref.slice(5), c.dir, c.size, c.key) : pngAlpha(c.ref);
        if (!ref) continue;
        if (ref.width !== shot.width || ref.height !== shot.height) {
            bad(`${c.lod}: reference is ${ref.width}x${ref.height}, the page drew ${shot.width}x${shot.height}`);
            continue;
        }
        let inter = 0, uni = 0, nPage = 0, nRef = 0;
        for (let i = 0; i < ref.alpha.length; i++) {
            const a = shot.alpha[i] > 0, b = fromPage ? ref.alpha[i] > 0 : ref.alpha[i] >= 128;
            nPage += a; nRef += b;
            if (a && b) inter++;
            if (a || b) uni++;
        }
        const iou = uni ? inter / uni : 1;
        const what = fromPage ? `the page's ${c.ref.slice(5)}` : `the evaluator's render (${path.basename(c.ref)})`;
        const msg = `${c.lod} from ${c.dir} at ${c.size} px: coverage IoU ${iou.toFixed(4)} against ${what} (${nPage} and ${nRef} px)`;
        if (iou >= 0.95 && nRef > 0) ok(msg);
        else bad(msg);
    }
    for (const b of blends) {
        const shot = await testRender(b.lod, b.dir, b.size, b.key);
        if (!shot) continue;
        // the crown: each row's pixels from its first to its last covered one
        let inside = 0, clear = 0;
        for (let y = 0; y < shot.height; y++) {
            const row = shot.alpha.slice(y * shot.width, (y + 1) * shot.width);
            const x0 = row.findIndex((a) => a > 0);
            if (x0 < 0) continue;
            let x1 = row.length - 1;
            while (row[x1] === 0) x1--;
            for (let x = x0; x <= x1; x++) { inside++; if (row[x] < 128) clear++; }
        }
        const f = inside ? clear / inside : 0;
        const msg = `${b.lod} (alpha BLEND leaves) from ${b.dir}: ${(100 * f).toFixed(1)} % of the ${inside} px inside the crown transparent (alpha < 128)`;
        if (f >= 0.15) ok(msg);
        else bad(msg + ', want >= 15 %: leaf cards drawn opaque?');
    }
    for (const p of panelSets) await checkPanels(p);
    for (const l of lums) await checkLuminance(l.key, l.size);
} finally {
    await browser.close();
}

// --panels: the page's test renders of bake key's panels, each as bright
// as the first (one colour pipeline for the original, three.js's materials
// and our shaders)
async function checkPanels({ key, dir, size, names }) {
    const page = await browser.newPage({ viewport: { width: 600, height: 600 }, deviceScaleFactor: 1 });
    page.on('pageerror', (e) => bad(`panels page: ${e}`));
    await page.goto(`${base}/v1/bakes/${key}/view?test=1`);
    if (!(await waitReady(page, `panels test-mode page of ${key.slice(0, 8)}`))) return;
    let ref = null;
    for (const spec of names) {
        const [lod, extra] = spec.split('?');
        let shot;
        try {
            shot = await page.evaluate(([l, d, s, f]) => window.sylvaViewer.draw(l, d, s, { fade: f }),
                [lod, dir.split(',').map(Number), size, /(^|&)fade=1(&|$)/.test(extra || '')]);
        } catch (e) {
            bad(`panel ${spec}: ${e.message.split('\n')[0]}`);
            continue;
        }
        if (ref === null) ref = shot.luminance;
        const ratio = ref > 0 ? shot.luminance / ref : 0;
        const msg = `viewer panel ${spec} from ${dir}: mean luminance ${shot.luminance.toFixed(4)} over ${shot.covered} px, ${ratio.toFixed(3)} of ${names[0]}'s`;
        if (shot.covered > 0 && Math.abs(ratio - 1) <= 0.07) ok(msg);
        else bad(msg + ' (want within 7 %: one colour pipeline)');
    }
    await page.close();
}

// --luminance: three.js's own GLTFLoader on each level file of bake key, in
// a page of the daemon's origin that maps 'three' to the copy sylvad serves
async function checkLuminance(key, size) {
    const page = await browser.newPage({ viewport: { width: 600, height: 600 }, deviceScaleFactor: 1 });
    page.on('pageerror', (e) => bad(`luminance page: ${e}`));
    const url = `${base}/v1/viewer/sylva-luminance-test.html`;
    await page.route(url, (route) => route.fulfill({
        contentType: 'text/html',
        body: `<!doctype html><html><head><script type="importmap">
{"imports": {"three": "./three/three.module.js", "three/addons/": "./three/addons/"}}
</script></head><body><script type="module">
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { MeshoptDecoder } from 'three/addons/libs/meshopt_decoder.module.js';
window.measure = async (bake, size) => {
    const report = await (await fetch(bake + 'artifacts/report.json')).json();
    const renderer = new THREE.WebGLRenderer({ alpha: true, preserveDrawingBuffer: true });
    renderer.setPixelRatio(1);
    renderer.setSize(size, size, false);
    renderer.setClearColor(0x000000, 0);
    const gl = renderer.getContext(), px = new Uint8Array(4 * size * size);
    const lin = (v) => (v <= 0.04045 ? v / 12.92 : Math.pow((v + 0.055) / 1.055, 2.4));
    const table = Array.from({ length: 256 }, (_, i) => lin(i / 255));
    let sphere = null, refMip = null, refNoMip = null;
    const out = [];
    for (const lod of report.lods) {
        const gltf = await new GLTFLoader().setMeshoptDecoder(MeshoptDecoder)
            .loadAsync(bake + 'artifacts/' + encodeURIComponent(lod.file));
        // plain unlit: the loader's material as MeshBasicMaterial
        gltf.scene.traverse((o) => {
            if (!o.isMesh) return;
            const m = o.material;
            o.material = new THREE.MeshBasicMaterial({ map: m.map, color: m.color, alphaTest: m.alphaTest,
                transparent: m.transparent, depthWrite: m.depthWrite, opacity: m.opacity, side: m.side });
        });
        const scene = new THREE.Scene();
        scene.add(gltf.scene);
        if (!sphere) sphere = new THREE.Box3().setFromObject(gltf.scene).getBoundingSphere(new THREE.Sphere());
        // ref: the first level's linear luminance per pixel of every view
        // (-1 where it draws nothing), for the ratio over the pixels both
        // draw (sveval's lum_ratio); null for the first level itself
        const views = (ref) => {
        let sum = 0, n = 0, both = 0, refBoth = 0, v = 0;
        const ys = new Float32Array(4 * size * size).fill(-1);
        for (const [az, el] of [[0, 10], [90, 10], [200, 10], [45, 45]]) {
            const a = az * Math.PI / 180, e = el * Math.PI / 180, r = sphere.radius;
            const d = new THREE.Vector3(Math.cos(e) * Math.sin(a), Math.sin(e), Math.cos(e) * Math.cos(a));
            const cam = new THREE.OrthographicCamera(-r, r, r, -r, 0.5 * r, 4 * r);
            cam.position.copy(sphere.center).addScaledVector(d, 2 * r);
            cam.lookAt(sphere.center);
            renderer.render(scene, cam);
            // the bytes the shader wrote (sRGB-encoded colour; a MASK
            // material writes its texel's alpha, so covered = alpha > 0)
            gl.readPixels(0, 0, size, size, gl.RGBA, gl.UNSIGNED_BYTE, px);
            for (let i = 0; i < px.length; i += 4) {
                if (px[i + 3] === 0) continue;
                const y = 0.2126 * table[px[i]] + 0.7152 * table[px[i + 1]] + 0.0722 * table[px[i + 2]];
                sum += y;
                n++;
                const j = v * size * size + i / 4;
                ys[j] = y;
                if (ref && ref[j] >= 0) {
                    both += y;
                    refBoth += ref[j];
                }
            }
            v++;
        }
        return { n, mean: n ? sum / n : 0, ys, ratio: ref ? (refBoth > 0 ? both / refBoth : 0) : 1 };
        };
        const first = out.length === 0;
        const asLoaded = views(first ? null : refMip);
        // the same without mipmaps (as sylva's renderer samples): a note
        // that tells the texture's transparent texels apart from its colour
        gltf.scene.traverse((o) => {
            if (!o.isMesh || !o.material.map) return;
            o.material.map.generateMipmaps = false;
            o.material.map.minFilter = THREE.LinearFilter;
            o.material.map.needsUpdate = true;
        });
        const noMip = views(first ? null : refNoMip);
        if (first) {
            refMip = asLoaded.ys;
            refNoMip = noMip.ys;
        }
        out.push({ name: lod.name, file: lod.file, pixels: asLoaded.n, mean: asLoaded.mean, noMip: noMip.mean,
            noMipPixels: noMip.n, both: asLoaded.ratio, noMipBoth: noMip.ratio });
    }
    return out;
};
window.measureReady = true;
</script></body></html>`,
    }));
    await page.goto(url);
    await page.waitForFunction(() => window.measureReady, null, { timeout: 30000 });
    const levels = await page.evaluate(([b, s]) => window.measure(b, s), [`${base}/v1/bakes/${key}/`, size]);
    await page.close();
    const ref = levels[0];
    for (const l of levels) {
        const ratio = ref.mean > 0 ? l.mean / ref.mean : 0;
        const nm = ref.noMip > 0 ? l.noMip / ref.noMip : 0;
        // Gated as loaded, with the mipmaps the files' samplers ask for (a
        // kept leaf texture black in its transparent texels darkened the
        // mesh levels at its mip levels, 1/1.24-1/1.32, until the bake
        // filled them: docs/outputs.md "Textures"), and without them
        // (sylva's and sveval's sampling). Printed beside: the ratio over
        // the pixels both levels draw (sveval's lum_ratio), since with
        // mipmaps the engine erodes the source leaf texture's alpha (the
        // bush's full mesh draws 13 % fewer pixels) and so changes each
        // level's mix of leaves and bark as well as its colour.
        const msg = `three.js GLTFLoader, unlit: ${l.name} (${l.file}) mean luminance with mipmaps ${ratio.toFixed(3)} of ${ref.name}'s over ${l.pixels} px, without mipmaps ${nm.toFixed(3)} over ${l.noMipPixels} px (means ${l.mean.toFixed(4)}, ${l.noMip.toFixed(4)}); over the pixels both draw ${l.both.toFixed(3)} with mipmaps, ${l.noMipBoth.toFixed(3)} without`;
        if (l.pixels > 0 && Math.abs(ratio - 1) <= 0.07 && Math.abs(nm - 1) <= 0.07) ok(msg);
        else bad(msg + ' (want both means within 7 %)');
    }
}
process.exit(failures ? 1 : 0);
