// octahedral.vert.glsl — sylva's octahedral impostor, vertex stage (GLSL ES 3.00).
// The contract is the conventions block of core/methods/octahedral/octahedral.h; every
// uniform and the impostor.json field it comes from: docs/runtime.md.
// Prepend "#version 300 es" (three.js: RawShaderMaterial, glslVersion GLSL3).
//
// Draws the LOD's proxy quad (model.glb, node impostor.json "node") as a
// square of half-size billboard_half about the frame centre, facing the
// viewer. The quad's attributes are not read: its four vertices are taken in
// sylva's quad corner order, vertex k = gl_VertexID % 4 at corner
// (-u,-v), (+u,-v), (+u,+v), (-u,+v) (planes.json "corners", triangles
// 0 1 2, 0 2 3), which is how sylva writes every quad. Everything the
// fragment stage needs is in object space, where impostor.json's centre,
// half and directions live (+Y up).
precision highp float;

uniform mat4 modelMatrix;       // object -> world (rotation, translation, uniform scale)
uniform mat4 viewMatrix;
uniform mat4 projectionMatrix;
uniform vec3 cameraPosition;    // world
uniform bool uOrtho;            // orthographic camera: every ray has the camera's direction
uniform vec3 uCentre;           // impostor.json lods[].centre
uniform float uBillboardHalf;   // impostor.json lods[].billboard_half

in vec3 position;               // not read (three.js needs an attribute to count vertices)

out vec3 vPos;                  // the point of the quad, object space
flat out vec3 vViewDir;         // unit, from the centre towards the viewer (frame selection)
flat out vec3 vCamPos;          // camera position, object space (perspective rays)

void main() {
    mat4 toObject = inverse(modelMatrix);
    vec3 camPos = (toObject * vec4(cameraPosition, 1.0)).xyz;
    // the camera's right and backward axes are the rows of the view matrix
    vec3 camRight = normalize((toObject * vec4(viewMatrix[0][0], viewMatrix[1][0], viewMatrix[2][0], 0.0)).xyz);
    vec3 camBack = normalize((toObject * vec4(viewMatrix[0][2], viewMatrix[1][2], viewMatrix[2][2], 0.0)).xyz);
    vec3 toViewer = uOrtho ? camBack : normalize(camPos - uCentre);
    vec3 right = normalize(camRight - dot(camRight, toViewer) * toViewer);
    vec3 up = cross(toViewer, right);
    const vec2 corners[4] = vec2[4](vec2(-1.0, -1.0), vec2(1.0, -1.0), vec2(1.0, 1.0), vec2(-1.0, 1.0));
    vec2 corner = corners[gl_VertexID % 4];
    vPos = uCentre + uBillboardHalf * (corner.x * right + corner.y * up);
    vViewDir = toViewer;
    vCamPos = camPos;
    gl_Position = projectionMatrix * viewMatrix * modelMatrix * vec4(vPos, 1.0);
}
