// stochastic.frag.glsl — continuous stochastic simplification, fragment stage (GLSL ES 3.00).
// Alpha test with the material's cutoff, then the fade as stochastic
// coverage: a fragment of a fading leaf is kept with probability vFade, a
// threshold hashed from the pixel (Cook et al.'s "fade by coverage"; Fichtner
// §4.3.3 dissolves the same way), so leaves need no sorting.
// Contrast preservation (colour pulled towards the mean by sqrt(mu)) is baked
// into sylva's per-level material copies; for a continuous form multiply the
// base colour by uContrast in the engine's own material.
// Colour is glTF's: uAlbedo an sRGB texture (decoded by the sampler), the
// factor linear, the result linear; SV_SRGB_OUTPUT encodes it to sRGB.
precision highp float;

uniform sampler2D uAlbedo;      // the leaf material's base-colour texture (sRGB: SRGB8_ALPHA8)
uniform vec4 uBaseColor;        // its baseColorFactor (linear)
uniform float uAlphaCutoff;     // its alphaCutoff (0.5 for MASK)

in vec2 vUv;
in float vFade;

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

float hash12(vec2 p) {
    vec3 p3 = fract(vec3(p.xyx) * 0.1031);
    p3 += dot(p3, p3.yzx + 33.33);
    return fract((p3.x + p3.y) * p3.z);
}

void main() {
    vec4 c = texture(uAlbedo, vUv) * uBaseColor;
    if (c.a < uAlphaCutoff) discard;
    if (vFade < 1.0 && vFade <= hash12(gl_FragCoord.xy)) discard;
    fragColor = vec4(svOutput(c.rgb), 1.0);
}
