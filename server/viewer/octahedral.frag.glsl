// octahedral.frag.glsl — sylva's octahedral impostor, fragment stage (GLSL ES 3.00).
// Implements the conventions block of core/methods/octahedral/octahedral.h, the same
// rules sylva's evaluator and `sylva-bake view` run in C (sv_octa_render):
// frame selection, ray-plane sampling of three frames, blend, alpha test.
// Optional parts, each behind a #define prepended by the engine:
//   SV_OCTA_NORMAL  lights the blend with the normal atlas (Lambert + ambient)
//   SV_OCTA_DEPTH   reads the depth atlas: each frame is sampled where the ray
//                   meets the surface it stores (SV_OCTA_PARALLAX_STEPS fixed-point
//                   steps from the frame plane, as sv_octa_render does), and
//                   gl_FragDepth is the blended surface point's depth
//   SV_SRGB_OUTPUT  encodes the output to sRGB (drawing straight to an sRGB
//                   display, as three.js's materials do); without it the
//                   output is linear, for an engine that encodes later
// Colour is glTF's: uAlbedo is an sRGB texture (SRGB8_ALPHA8: decoded before
// filtering), frames are blended in linear colour, as sv_octa_render does.
// Uniforms and the impostor.json fields they come from: docs/runtime.md.
precision highp float;
precision highp int;

uniform mat4 modelMatrix;
uniform mat4 viewMatrix;
uniform mat4 projectionMatrix;
uniform bool uOrtho;
uniform sampler2D uAlbedo;      // one image of mips[]: mips[uMip] (mips[0] = maps.albedo), SRGB8_ALPHA8
                                // (sRGB colour, linear alpha), straight colour, row 0 = the image's
                                // top (flipY off), sampled
                                // bilinear at its level 0 (no mip chain inside the texture:
                                // frames must not bleed into each other)
uniform int uGrid;              // grid: N frames per side
uniform bool uHemi;             // hemi
uniform float uElevScale;       // elevation_scale: S in (0, 1], 1 = Brucks' layout
uniform float uFramePixels;     // frame_pixels: F, texels per frame side of maps.albedo
uniform int uMip;               // which mip uAlbedo holds: its frames are F >> uMip texels
uniform vec3 uCentre;           // centre
uniform float uHalf;            // half: frame half extent
uniform float uAlphaCutoff;     // alpha_cutoff (0.5)
#ifdef SV_OCTA_NORMAL
uniform sampler2D uNormal;      // maps.normal (uMip 0 only): RGB = 0.5 + 0.5 n in the frame basis (right, up, d)
uniform vec3 uLightDir;         // unit, towards the light, object space
uniform float uAmbient;
#endif
#ifdef SV_OCTA_DEPTH
uniform sampler2D uDepth;       // maps.depth (uMip 0 only): 0.5 + 0.5 s/half, s along d towards the viewer;
                                // 16-bit R (unorm16 or float), or with SV_OCTA_DEPTH_RG8 two bytes
                                // R = high, G = low (WebGL2 has no filterable 16-bit unorm format)
#endif

in vec3 vPos;
flat in vec3 vViewDir;
flat in vec3 vCamPos;

out vec4 fragColor;

// linear to sRGB, as three.js encodes its own materials' output
// (sRGBTransferOETF) when drawing to an sRGB canvas
vec3 svOutput(vec3 c) {
#ifdef SV_SRGB_OUTPUT
    return mix(pow(c, vec3(0.41666)) * 1.055 - vec3(0.055), c * 12.92, vec3(lessThanEqual(c, vec3(0.0031308))));
#else
    return c;
#endif
}

// uv in [-1,1]^2 of unit direction d (sv_octa_encode)
vec2 octaEncode(vec3 d) {
    d.y /= uElevScale;
    if (uHemi) {
        d.y = max(d.y, 0.0);
        vec3 p = d / (abs(d.x) + abs(d.y) + abs(d.z));
        return vec2(p.x + p.z, p.x - p.z);
    }
    vec3 p = d / (abs(d.x) + abs(d.y) + abs(d.z));
    if (p.y >= 0.0) return p.xz;
    vec2 s = vec2(p.x >= 0.0 ? 1.0 : -1.0, p.z >= 0.0 ? 1.0 : -1.0);
    return vec2((1.0 - abs(p.z)) * s.x, (1.0 - abs(p.x)) * s.y);
}

// unit direction of uv (sv_octa_decode)
vec3 octaDecode(vec2 uv) {
    vec3 p;
    if (uHemi) {
        p.x = 0.5 * (uv.x + uv.y);
        p.z = 0.5 * (uv.x - uv.y);
        p.y = 1.0 - abs(p.x) - abs(p.z);
    } else {
        p.y = 1.0 - abs(uv.x) - abs(uv.y);
        if (p.y >= 0.0) {
            p.xz = uv;
        } else {
            vec2 s = vec2(uv.x >= 0.0 ? 1.0 : -1.0, uv.y >= 0.0 ? 1.0 : -1.0);
            p.x = (1.0 - abs(uv.y)) * s.x;
            p.z = (1.0 - abs(uv.x)) * s.y;
        }
    }
    p.y *= uElevScale;
    return normalize(p);
}

// direction of frame (i, j): the one that decodes from g = (i, j)
vec3 frameDir(ivec2 ij) {
    return octaDecode(vec2(ij) / float(uGrid - 1) * 2.0 - 1.0);
}

// right and up of the frame seen from d (sv_octa_frame_basis)
void frameBasis(vec3 d, out vec3 right, out vec3 up) {
    vec3 ref = vec3(0.0, 1.0, 0.0);
    if (abs(d.y) > 0.9999) ref = vec3(0.0, 0.0, d.y > 0.0 ? -1.0 : 1.0);
    right = normalize(cross(ref, d));
    up = cross(d, right);
}

#ifdef SV_OCTA_DEPTH
float depthAt(vec2 uv) {
    vec4 t = textureLod(uDepth, uv, 0.0);
#ifdef SV_OCTA_DEPTH_RG8
    return dot(t.rg, vec2(65280.0, 255.0) / 65535.0);
#else
    return t.r;
#endif
}
#endif

#ifndef SV_OCTA_PARALLAX_STEPS
#define SV_OCTA_PARALLAX_STEPS 3
#endif

struct Sample {
    vec4 albedo;    // straight rgb, a (0 when the ray misses the frame)
    vec3 normal;    // object space (SV_OCTA_NORMAL)
    vec3 pos;       // the surface point, relative to the centre (SV_OCTA_DEPTH)
};

// atlas uv of frame point st in frame ij, frames of F texels: bilinear with
// texel centres clamped inside the frame
vec2 atlasUv(ivec2 ij, vec2 st, float F) {
    vec2 xy = clamp(st * F, vec2(0.5), vec2(F - 0.5));
    return (vec2(ij) * F + xy) / (float(uGrid) * F);
}

Sample sampleFrame(ivec2 ij, vec3 D) {
    Sample s;
    s.albedo = vec4(0.0);
    s.normal = vec3(0.0);
    s.pos = vec3(0.0);
    vec3 d = frameDir(ij);
    float dd = dot(D, d);
    if (dd <= 1e-4) return s;
    vec3 right, up;
    frameBasis(d, right, up);
    vec3 q = vPos - uCentre;
    float a0 = dot(q, d), off = 0.0;
    float F = max(floor(uFramePixels / exp2(float(uMip))), 1.0), F0 = uFramePixels;
    vec3 P;
    vec2 st;
    bool inside = false;
    // start on the frame plane; with a depth map, move SV_OCTA_PARALLAX_STEPS
    // times to the ray's point at the height stored where the last point projects
    for (int it = 0; it <= SV_OCTA_PARALLAX_STEPS; it++) {
        float tt = (a0 - off) / dd;
        P = q - tt * D - off * d;
        st = vec2(dot(P, right) / uHalf * 0.5 + 0.5, 0.5 - dot(P, up) / uHalf * 0.5);
        inside = all(greaterThanEqual(st, vec2(0.0))) && all(lessThanEqual(st, vec2(1.0)));
#ifdef SV_OCTA_DEPTH
        if (!inside || it == SV_OCTA_PARALLAX_STEPS) break;
        off = (depthAt(atlasUv(ij, st, F0)) - 0.5) * 2.0 * uHalf;
#else
        break;
#endif
    }
    if (!inside) return s;
    s.albedo = textureLod(uAlbedo, atlasUv(ij, st, F), 0.0);
    if (!(s.albedo.a > 0.0)) {
        s.albedo = vec4(0.0);
        return s;
    }
#ifdef SV_OCTA_NORMAL
    vec3 n = textureLod(uNormal, atlasUv(ij, st, F0), 0.0).xyz * 2.0 - 1.0;
    s.normal = n.x * right + n.y * up + n.z * d;
#endif
#ifdef SV_OCTA_DEPTH
    float h = (depthAt(atlasUv(ij, st, F0)) - 0.5) * 2.0 * uHalf;
    s.pos = P + h * d;
#endif
    return s;
}

void main() {
    int N = uGrid;
    vec3 D = uOrtho ? vViewDir : normalize(vCamPos - vPos);   // towards the viewer
    vec2 g = (octaEncode(vViewDir) * 0.5 + 0.5) * float(N - 1);
    ivec2 c = min(ivec2(floor(g)), ivec2(N - 2));
    vec2 f = g - vec2(c);
    ivec2 k0, k1 = c + ivec2(1, 0), k2 = c + ivec2(0, 1);
    vec3 w;
    if (f.x + f.y <= 1.0) {
        k0 = c;
        w = vec3(1.0 - f.x - f.y, f.x, f.y);
    } else {
        k0 = c + ivec2(1, 1);
        w = vec3(f.x + f.y - 1.0, 1.0 - f.y, 1.0 - f.x);
    }
    Sample s0 = sampleFrame(k0, D), s1 = sampleFrame(k1, D), s2 = sampleFrame(k2, D);
    vec3 wa = w * vec3(s0.albedo.a, s1.albedo.a, s2.albedo.a);
    float a = wa.x + wa.y + wa.z;
    if (a < uAlphaCutoff) discard;
    vec3 rgb = (wa.x * s0.albedo.rgb + wa.y * s1.albedo.rgb + wa.z * s2.albedo.rgb) / a;
#ifdef SV_OCTA_NORMAL
    vec3 n = normalize(wa.x * s0.normal + wa.y * s1.normal + wa.z * s2.normal);
    rgb *= uAmbient + (1.0 - uAmbient) * max(dot(n, uLightDir), 0.0);
#endif
#ifdef SV_OCTA_DEPTH
    vec3 surface = uCentre + (wa.x * s0.pos + wa.y * s1.pos + wa.z * s2.pos) / a;
    vec4 clip = projectionMatrix * viewMatrix * modelMatrix * vec4(surface, 1.0);
    gl_FragDepth = 0.5 + 0.5 * clip.z / clip.w;
#endif
    fragColor = vec4(svOutput(rgb), 1.0);
}
