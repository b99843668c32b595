// stochastic.vert.glsl — continuous stochastic simplification, vertex stage (GLSL ES 3.00).
// docs/methods/stochastic.md (Cook et al. 2007, Fichtner): draws any prefix of
// a stochastic LOD's leaves, scaled to keep the crown's area, fading across
// the window [mu - R, mu + R] of the leaf order instead of popping.
// Reads the glTF attributes sylva writes on stochastic levels:
//   _LEAF_CENTRE (VEC3)   the leaf's centre (trunk vertices: their own position)
//   _LEAF_ORDER (SCALAR)  (position in the order + 0.5) / N; 0 on the trunk
// (three.js's GLTFLoader names them _leaf_centre and _leaf_order.)
// Prepend "#version 300 es" (three.js: RawShaderMaterial, glslVersion GLSL3).
precision highp float;

uniform mat4 modelMatrix;
uniform mat4 viewMatrix;
uniform mat4 projectionMatrix;
uniform float uMu;              // fraction of the leaves drawn, (0, 1]
uniform float uFade;            // extras.sylva_stochastic.fade_radius: R
uniform float uAreaScale;       // s(r, mu) = (1 - (1 - r)^(1/mu)) / r, r = extras visible_ratio
uniform float uAreaGamma;       // extras.sylva_stochastic.area_gamma: gamma (1 = Cook's sqrt(s))

in vec3 position;
in vec2 uv;
in vec3 _leaf_centre;
in float _leaf_order;

out vec2 vUv;
out float vFade;

void main() {
    float o = _leaf_order;
    vec3 p = position;
    vFade = 1.0;
    if (o > 0.0) {
        // the paper's window: leaves before mu - R stay, after mu + R go,
        // in between their coverage falls linearly
        float R = min(uFade, 1.0 - uMu);
        vFade = R > 0.0 ? clamp((uMu + R - o) / (2.0 * R), 0.0, 1.0) : (o <= uMu ? 1.0 : 0.0);
        if (vFade <= 0.0) {
            p = _leaf_centre;           // collapsed: no fragment
        } else {
            float k = pow(max(uAreaScale, 1.0), 0.5 * uAreaGamma);
            p = _leaf_centre + k * (position - _leaf_centre);
        }
    }
    vUv = uv;
    gl_Position = projectionMatrix * viewMatrix * modelMatrix * vec4(p, 1.0);
}
