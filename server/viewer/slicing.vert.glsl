// slicing.vert.glsl — the blending rule of a `slicing` LOD, vertex stage (GLSL ES 3.00).
// docs/methods/slicing.md, "The blending rule"; planes.json lods[].slicing.
// Prepend "#version 300 es" (three.js: RawShaderMaterial, glslVersion GLSL3).
//
// Draws the LOD's quads (the atlas primitive of lod<i>_slicing.glb) with a
// per-vertex slicing index `slicing` = planes.json quads[q].group for the
// four vertices of quad q (triangles 2q and 2q+1): glTF has no such
// attribute, so the engine adds it once at load time (docs/runtime.md).
// Each vertex computes its slicing's weight for the current view direction
// (the same for every vertex of the LOD) and hands it to the fragment stage.
precision highp float;

uniform mat4 modelMatrix;
uniform mat4 viewMatrix;
uniform mat4 projectionMatrix;
uniform vec3 cameraPosition;    // world
uniform bool uOrtho;
uniform vec3 uCentre;           // the point the view direction is taken from (the bounds' centre)
uniform int uSlicings;          // slicing.azimuthal_slicings: S
uniform float uStepDeg;         // slicing.azimuth_step_deg: 180 / S
uniform bool uTop;              // slicing.top: group S is the top slicing

in vec3 position;
in vec2 uv;
in float slicing;               // the quad's group

out vec2 vUv;
out float vWeight;

const float PI = 3.14159265358979;

// the rule's weight of slicing `group` for unit view direction v (either sign)
float slicingWeight(vec3 v, int group) {
    float phi = (abs(v.x) + abs(v.z) < 1e-9) ? 0.0 : degrees(atan(v.x, v.z));
    phi = mod(phi, 180.0);
    if (phi >= 180.0) phi = 0.0;
    float t = phi / uStepDeg;
    int j = int(floor(t));
    float f = t - float(j);
    j = j % uSlicings;
    float horiz = 1.0;
    if (uTop) {
        float e = degrees(asin(clamp(abs(v.y), 0.0, 1.0)));
        horiz = 1.0 - e / 90.0;
        if (group == uSlicings) return e / 90.0;
    }
    float w = 0.0;
    if (group == j) w += 1.0 - f;
    if (group == (j + 1) % uSlicings) w += f;
    return w * horiz;
}

void main() {
    mat4 toObject = inverse(modelMatrix);
    vec3 back = vec3(viewMatrix[0][2], viewMatrix[1][2], viewMatrix[2][2]);
    vec3 v = uOrtho ? normalize((toObject * vec4(back, 0.0)).xyz)
                    : normalize((toObject * vec4(cameraPosition, 1.0)).xyz - uCentre);
    vWeight = slicingWeight(v, int(slicing + 0.5));
    vUv = uv;
    gl_Position = projectionMatrix * viewMatrix * modelMatrix * vec4(position, 1.0);
}
