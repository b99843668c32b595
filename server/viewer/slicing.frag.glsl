// slicing.frag.glsl — the blending rule of a `slicing` LOD, fragment stage (GLSL ES 3.00).
// Each slicing is alpha-tested on its own (the atlas' binary alpha, the
// material's cutoff) and then drawn with its weight, one of two ways:
//   default          stochastic (dithered) coverage: a fragment is kept with
//                    probability = weight (a fixed 4x4 Bayer threshold), drawn
//                    opaque, so it needs no sorting and writes depth; averaged
//                    over a few pixels it is the weighted blend
//   SV_SLICING_BLEND alpha = weight, for alpha blending (SRC_ALPHA,
//                    ONE_MINUS_SRC_ALPHA) with depth writes off: the exact
//                    weighted sum when the two slicings do not overlap,
//                    order-dependent where they do
// Slicings of weight 0 draw nothing; the trunk mesh is drawn as it is.
// Colour is glTF's: uAlbedo an sRGB texture (decoded by the sampler), the
// result linear; SV_SRGB_OUTPUT encodes it to sRGB.
precision highp float;

uniform sampler2D uAlbedo;      // planes.json atlas.albedo, sRGB (SRGB8_ALPHA8; glTF convention: v down, flipY off)
uniform float uAlphaCutoff;     // the atlas material's alphaCutoff

in vec2 vUv;
in float vWeight;

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

float bayer4(vec2 p) {
    ivec2 i = ivec2(mod(p, 4.0));
    int m[16] = int[16](0, 8, 2, 10, 12, 4, 14, 6, 3, 11, 1, 9, 15, 7, 13, 5);
    return (float(m[i.y * 4 + i.x]) + 0.5) / 16.0;
}

void main() {
    if (vWeight <= 0.0) discard;
    vec4 c = texture(uAlbedo, vUv);
    if (c.a < uAlphaCutoff) discard;
#ifdef SV_SLICING_BLEND
    fragColor = vec4(svOutput(c.rgb), vWeight);
#else
    if (vWeight < 1.0 && vWeight <= bayer4(gl_FragCoord.xy)) discard;
    fragColor = vec4(svOutput(c.rgb), 1.0);
#endif
}
