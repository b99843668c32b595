/* render_osmesa.c — the OSMesa (Mesa llvmpipe) backend of render.h; the only file
 * in sylva that includes GL headers.
 *
 * Choices, stated once:
 *   - Context: OSMesaCreateContextAttribs, compatibility profile 3.0 (GLSL 1.30),
 *     made current on a tiny 4×4 buffer; all drawing goes to one framebuffer
 *     object (32-bit float depth; colour RGBA16 for the colour shades, RGBA8
 *     for normals and SV_SHADE_ALPHA_MAX, attached per draw) that grows to the
 *     largest size asked for, never beyond max_size.
 *   - Determinism: LP_NUM_THREADS is forced to "2" and GALLIUM_DRIVER to
 *     "llvmpipe" (setenv, before every context creation; the values never
 *     change). llvmpipe bins per tile and shades each tile in one thread, so the
 *     output does not depend on scheduling; tests render twice and compare bytes.
 *   - Textures: uploaded once per sv_gpu_mesh, GL_LINEAR without mipmaps,
 *     GL_REPEAT (glTF's default sampler). 8-bit images are sRGB colour
 *     (image.h): stored as GL_SRGB8(_ALPHA8), so the sampler decodes each
 *     texel to linear before filtering, as a glTF engine does; 16-bit images
 *     are taken as linear. Bakes render supersampled, so linear
 *     filtering at the source resolution is the faithful choice; mipmaps would
 *     average alpha and erode alpha-tested leaves.
 *   - Materials: colour = base_color × texture, both linear (glTF's
 *     baseColorFactor and the decoded texel), rendered into 16 bits per
 *     channel and read back linear (sv_render_options.linear) or encoded
 *     with the exact sRGB OETF into RGBA8; MASK discards alpha < cutoff,
 *     BLEND is MASK with cutoff 0.5, OPAQUE ignores alpha. Every fragment that is
 *     drawn writes alpha 1, so the output alpha is coverage (binary).
 *   - Two-sided: no culling; the shading normal is flipped on back faces
 *     (gl_FrontFacing) so it faces the camera.
 *   - Precision: vertex positions are uploaded relative to the mesh's bounding-box
 *     centre (computed in double), so meshes far from the origin keep float
 *     precision; the camera transform is built in double.
 *   - Depth: orthographic, so window depth is linear in the distance along
 *     forward: dist = near + z_w (far - near); z_w == 1 (the clear value, which
 *     GL_LESS never writes) means nothing was drawn → INFINITY.
 */
#define GL_GLEXT_PROTOTYPES 1
#include <GL/osmesa.h>
#include <GL/gl.h>
#include <GL/glext.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "image.h"
#include "render.h"

#define SV_RENDER_THREADS "2"

struct sv_renderer {
    OSMesaContext ctx;
    uint8_t front[4 * 4 * 4]; /* the buffer OSMesa is made current on */
    uint32_t max_size;
    /* full: every shading mode; albedo: SV_SHADE_ALBEDO only (VS_SRC, FS_SRC) */
    struct gl_prog {
        GLuint id;
        GLint u_mvp, u_ncam, u_base, u_has_tex, u_cutoff, u_shade, u_light, u_ambient, u_tex;
        bool normals; /* reads a_nrm */
    } full, albedo;
    GLuint fbo, rb_color, rb_color16, rb_depth;
    uint32_t fb_w, fb_h; /* allocated size of the renderbuffers */
    GLuint ibo;          /* per-call index buffer (subset draws) */
    bool pack_invert;    /* GL_MESA_pack_invert is on: glReadPixels gives the top row first */
    /* Textures shared by the meshes whose images share pixels (sv_image_copy):
     * a tree's textures were uploaded again for every level. Each entry holds a copy of its image, so
     * the pixels, whose address is the key, cannot be freed and reused while
     * the texture lives. */
    struct tex_entry {
        sv_image img;
        GLuint tex;
        uint32_t users;
    } * tex_cache;
    uint32_t tex_count, tex_cap;
    /* Scratch kept from one render to the next (grown, never shrunk): the
     * index list and the RGBA16 read-back. Fresh buffers of these sizes
     * each render were page-faulted in every time (glibc hands large blocks
     * back to the kernel; ASan maps each one anew): up to a third of a
     * texture bake's time. */
    uint32_t *idx;
    size_t idx_cap; /* entries */
    uint16_t *rb16;
    size_t rb16_cap; /* entries */
};

/* *buf with room for n entries of `size` bytes (contents not kept), or NULL. */
static void *scratch(void **buf, size_t *cap, size_t n, size_t size)
{
    if (n <= *cap && *buf) return *buf;
    size_t bytes;
    if (!sv_mul_size(n ? n : 1, size, &bytes)) return NULL;
    free(*buf);
    *buf = malloc(bytes);
    *cap = *buf ? n : 0;
    return *buf;
}

struct sv_gpu_mesh {
    sv_renderer *r;
    const sv_mesh *mesh;
    double centre[3]; /* positions are uploaded relative to this */
    GLuint vbo;       /* interleaved pos3 normal3 uv2 floats */
    GLuint *textures; /* one per image, 0 when the image is unusable */
    uint32_t texture_count;
};

/* One vertex and one fragment shader, built twice: with SV_NORMALS (every
 * shading mode: u_shade 0 albedo, 1 normal, 2 lit) and without (the albedo
 * program, no normal varying: cheaper, and the same pixels, since albedo
 * never reads the normal). Each
 * source follows the "#version 130" line and the defines (shader_head).
 * u_cutoff < 0: opaque (no alpha test); below -1.5: no alpha test and the
 * fragment's alpha written instead of 1 (SV_SHADE_ALPHA_MAX's swept materials). */
static const char *VS_SRC = "in vec3 a_pos; in vec2 a_uv;\n"
                            "uniform mat4 u_mvp;\n"
                            "out vec2 v_uv;\n"
                            "#ifdef SV_NORMALS\n"
                            "in vec3 a_nrm; uniform mat3 u_ncam; out vec3 v_n;\n"
                            "#endif\n"
                            "void main() {\n"
                            "#ifdef SV_NORMALS\n"
                            "  v_n = u_ncam * a_nrm;\n"
                            "#endif\n"
                            "  v_uv = a_uv;\n"
                            "  gl_Position = u_mvp * vec4(a_pos, 1.0);\n"
                            "}\n";

static const char *FS_SRC =
    "in vec2 v_uv;\n"
    "uniform vec4 u_base; uniform int u_has_tex; uniform float u_cutoff;\n"
    "uniform sampler2D u_tex;\n"
    "out vec4 o_color;\n"
    "#ifdef SV_NORMALS\n"
    "in vec3 v_n;\n"
    "uniform int u_shade; uniform vec3 u_light; uniform float u_ambient;\n"
    "#endif\n"
    "void main() {\n"
    "  vec4 c = u_base;\n"
    "  if (u_has_tex != 0) c *= texture(u_tex, v_uv);\n"
    "  if (u_cutoff >= 0.0 && c.a < u_cutoff) discard;\n"
    "#ifdef SV_NORMALS\n"
    "  vec3 n = v_n;\n"
    "  float len = length(n);\n"
    "  n = len > 0.0 ? n / len : vec3(0.0, 0.0, 1.0);\n"
    "  if (!gl_FrontFacing) n = -n;\n"
    "  if (u_shade == 1) { o_color = vec4(0.5 + 0.5 * n, 1.0); return; }\n"
    "  if (u_shade == 2) {\n"
    "    float k = u_ambient + (1.0 - u_ambient) * max(dot(n, u_light), 0.0);\n"
    "    c.rgb *= k;\n"
    "  }\n"
    "#endif\n"
    "  o_color = vec4(clamp(c.rgb, 0.0, 1.0), u_cutoff < -1.5 ? c.a : 1.0);\n"
    "}\n";

/* The lines before a source: its version and, for the full program, the define. */
static const char *shader_head(bool normals)
{
    return normals ? "#version 130\n#define SV_NORMALS\n" : "#version 130\n";
}

void sv_camera_forward(const sv_camera *cam, double f[3])
{
    const double *u = cam->up, *r = cam->right;
    f[0] = u[1] * r[2] - u[2] * r[1];
    f[1] = u[2] * r[0] - u[0] * r[2];
    f[2] = u[0] * r[1] - u[1] * r[0];
}

static sv_status gl_check(sv_error *err, const char *what)
{
    GLenum e = glGetError();
    if (e != GL_NO_ERROR)
        return sv_fail(err, SV_ERR_RENDER, "render: GL error 0x%x during %s", (unsigned)e, what);
    return SV_OK;
}

static bool make_current(sv_renderer *r)
{
    if (OSMesaGetCurrentContext() == r->ctx) return true;
    return OSMesaMakeCurrent(r->ctx, r->front, GL_UNSIGNED_BYTE, 4, 4) == GL_TRUE;
}

static GLuint compile(GLenum type, const char *head, const char *src, sv_error *err)
{
    GLuint s = glCreateShader(type);
    const char *parts[2] = {head, src};
    glShaderSource(s, 2, parts, NULL);
    glCompileShader(s);
    GLint ok = 0;
    glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
    if (!ok) {
        char log[400] = {0};
        glGetShaderInfoLog(s, (GLsizei)sizeof log - 1, NULL, log);
        sv_fail(err, SV_ERR_RENDER, "render: shader compile failed: %s", log);
        glDeleteShader(s);
        return 0;
    }
    return s;
}

/* Compiles and links VS_SRC and FS_SRC, with or without SV_NORMALS, into *out
 * (uniform locations: -1 for the ones it does not use, which glUniform then
 * ignores). */
static sv_status build_program(bool normals, struct gl_prog *out, sv_error *err)
{
    GLuint vs = compile(GL_VERTEX_SHADER, shader_head(normals), VS_SRC, err);
    if (!vs) return SV_ERR_RENDER;
    GLuint fs = compile(GL_FRAGMENT_SHADER, shader_head(normals), FS_SRC, err);
    if (!fs) {
        glDeleteShader(vs);
        return SV_ERR_RENDER;
    }
    GLuint p = glCreateProgram();
    glAttachShader(p, vs);
    glAttachShader(p, fs);
    glBindAttribLocation(p, 0, "a_pos");
    if (normals) glBindAttribLocation(p, 1, "a_nrm");
    glBindAttribLocation(p, 2, "a_uv");
    glBindFragDataLocation(p, 0, "o_color");
    glLinkProgram(p);
    glDeleteShader(vs);
    glDeleteShader(fs);
    GLint ok = 0;
    glGetProgramiv(p, GL_LINK_STATUS, &ok);
    if (!ok) {
        char log[400] = {0};
        glGetProgramInfoLog(p, (GLsizei)sizeof log - 1, NULL, log);
        glDeleteProgram(p);
        return sv_fail(err, SV_ERR_RENDER, "render: shader link failed: %s", log);
    }
    out->id = p;
    out->normals = normals;
    out->u_mvp = glGetUniformLocation(p, "u_mvp");
    out->u_ncam = glGetUniformLocation(p, "u_ncam");
    out->u_base = glGetUniformLocation(p, "u_base");
    out->u_has_tex = glGetUniformLocation(p, "u_has_tex");
    out->u_cutoff = glGetUniformLocation(p, "u_cutoff");
    out->u_shade = glGetUniformLocation(p, "u_shade");
    out->u_light = glGetUniformLocation(p, "u_light");
    out->u_ambient = glGetUniformLocation(p, "u_ambient");
    out->u_tex = glGetUniformLocation(p, "u_tex");
    return SV_OK;
}

sv_status sv_renderer_create(uint32_t max_size, sv_renderer **out, sv_error *err)
{
    *out = NULL;
    if (max_size == 0) return sv_fail(err, SV_ERR_RENDER, "render: max_size must be positive");
    /* Fixed rasteriser configuration, for byte-identical output (see top). */
    setenv("GALLIUM_DRIVER", "llvmpipe", 1);
    setenv("LP_NUM_THREADS", SV_RENDER_THREADS, 1);

    sv_renderer *r = calloc(1, sizeof *r);
    if (!r) return sv_fail(err, SV_ERR_NOMEM, "render: out of memory");
    const int attribs[] = {OSMESA_FORMAT,
                           OSMESA_RGBA,
                           OSMESA_DEPTH_BITS,
                           0,
                           OSMESA_STENCIL_BITS,
                           0,
                           OSMESA_ACCUM_BITS,
                           0,
                           OSMESA_PROFILE,
                           OSMESA_COMPAT_PROFILE,
                           OSMESA_CONTEXT_MAJOR_VERSION,
                           3,
                           OSMESA_CONTEXT_MINOR_VERSION,
                           0,
                           0};
    r->ctx = OSMesaCreateContextAttribs(attribs, NULL);
    if (!r->ctx) {
        free(r);
        return sv_fail(err, SV_ERR_RENDER,
                       "render: OSMesaCreateContextAttribs failed "
                       "(compatibility profile 3.0)");
    }
    if (!make_current(r)) {
        OSMesaDestroyContext(r->ctx);
        free(r);
        return sv_fail(err, SV_ERR_RENDER, "render: OSMesaMakeCurrent failed");
    }
    GLint max_rb = 0, max_vp[2] = {0, 0};
    glGetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &max_rb);
    glGetIntegerv(GL_MAX_VIEWPORT_DIMS, max_vp);
    uint32_t cap = (uint32_t)max_rb;
    if ((uint32_t)max_vp[0] < cap) cap = (uint32_t)max_vp[0];
    if ((uint32_t)max_vp[1] < cap) cap = (uint32_t)max_vp[1];
    r->max_size = max_size < cap ? max_size : cap;
    sv_status st = build_program(true, &r->full, err);
    if (st == SV_OK) st = build_program(false, &r->albedo, err);
    if (st != SV_OK) {
        sv_renderer_destroy(r);
        return st;
    }
    glGenFramebuffers(1, &r->fbo);
    glGenRenderbuffers(1, &r->rb_color);
    glGenRenderbuffers(1, &r->rb_color16);
    glGenRenderbuffers(1, &r->rb_depth);
    glGenBuffers(1, &r->ibo);
    glDisable(GL_CULL_FACE);
    glDisable(GL_BLEND);
    glDisable(GL_DITHER);
    glDisable(GL_MULTISAMPLE);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    /* Read-backs in sylva's row order (row 0 at the top) straight from GL
     * when Mesa offers it: no row flip, no staging buffer for depth (the
     * evaluator reads back two images per view). Same bytes. */
    GLint next = 0;
    glGetIntegerv(GL_NUM_EXTENSIONS, &next);
    for (GLint i = 0; i < next && !r->pack_invert; i++) {
        const GLubyte *name = glGetStringi(GL_EXTENSIONS, (GLuint)i);
        r->pack_invert = name && strcmp((const char *)name, "GL_MESA_pack_invert") == 0;
    }
    if (r->pack_invert) glPixelStorei(GL_PACK_INVERT_MESA, GL_TRUE);
    st = gl_check(err, "renderer setup");
    if (st != SV_OK) {
        sv_renderer_destroy(r);
        return st;
    }
    *out = r;
    return SV_OK;
}

uint32_t sv_renderer_max_size(const sv_renderer *r)
{
    return r ? r->max_size : 0;
}

void sv_renderer_destroy(sv_renderer *r)
{
    if (!r) return;
    if (make_current(r)) {
        if (r->full.id) glDeleteProgram(r->full.id);
        if (r->albedo.id) glDeleteProgram(r->albedo.id);
        if (r->fbo) glDeleteFramebuffers(1, &r->fbo);
        if (r->rb_color) glDeleteRenderbuffers(1, &r->rb_color);
        if (r->rb_color16) glDeleteRenderbuffers(1, &r->rb_color16);
        if (r->rb_depth) glDeleteRenderbuffers(1, &r->rb_depth);
        if (r->ibo) glDeleteBuffers(1, &r->ibo);
        for (uint32_t i = 0; i < r->tex_count; i++) glDeleteTextures(1, &r->tex_cache[i].tex);
    }
    for (uint32_t i = 0; i < r->tex_count; i++) sv_image_free(&r->tex_cache[i].img);
    free(r->tex_cache);
    free(r->idx);
    free(r->rb16);
    OSMesaMakeCurrent(NULL, NULL, 0, 0, 0);
    OSMesaDestroyContext(r->ctx);
    free(r);
}

static GLuint upload_texture_gl(const sv_image *img)
{
    if (!img->data || img->width == 0 || img->height == 0 || img->channels < 1 ||
        img->channels > 4 || (img->bits != 8 && img->bits != 16))
        return 0;
    static const GLenum formats[4] = {GL_LUMINANCE, GL_LUMINANCE_ALPHA, GL_RGB, GL_RGBA};
    GLenum fmt = formats[img->channels - 1];
    GLuint t = 0;
    glGenTextures(1, &t);
    glBindTexture(GL_TEXTURE_2D, t);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_REPEAT);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_REPEAT);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
    /* Row 0 of sv_image is the top row and glTF's v=0 is the top: uploading
     * top-row-first makes texture t = glTF v with no flip. */
    GLint internal = img->channels == 3 ? GL_RGB8 : GL_RGBA8;
    if (img->bits == 8) internal = img->channels == 3 ? GL_SRGB8 : GL_SRGB8_ALPHA8;
    glTexImage2D(GL_TEXTURE_2D, 0, internal, (GLsizei)img->width, (GLsizei)img->height, 0, fmt,
                 img->bits == 8 ? GL_UNSIGNED_BYTE : GL_UNSIGNED_SHORT, img->data);
    return t;
}

/* img's texture: the renderer's, when an image sharing its pixels was
 * uploaded before (one more user), else a new one (cached when its pixels
 * are shareable). 0 when the image is unusable. */
static GLuint upload_texture(sv_renderer *r, const sv_image *img)
{
    for (uint32_t i = 0; img->refs && i < r->tex_count; i++) {
        const sv_image *c = &r->tex_cache[i].img;
        if (c->data == img->data && c->width == img->width && c->height == img->height &&
            c->channels == img->channels && c->bits == img->bits) {
            r->tex_cache[i].users++;
            return r->tex_cache[i].tex;
        }
    }
    GLuint t = upload_texture_gl(img);
    if (!t || !img->refs) return t;
    if (r->tex_count == r->tex_cap) {
        uint32_t cap = r->tex_cap ? 2 * r->tex_cap : 8;
        struct tex_entry *e = realloc(r->tex_cache, cap * sizeof *e);
        if (!e) return t; /* not shared, still usable */
        r->tex_cache = e;
        r->tex_cap = cap;
    }
    struct tex_entry *e = &r->tex_cache[r->tex_count];
    if (sv_image_copy(img, &e->img, NULL) != SV_OK) return t;
    e->tex = t;
    e->users = 1;
    r->tex_count++;
    return t;
}

/* Releases one user of texture t (deleted with its last). */
static void release_texture(sv_renderer *r, GLuint t)
{
    for (uint32_t i = 0; i < r->tex_count; i++) {
        if (r->tex_cache[i].tex != t) continue;
        if (--r->tex_cache[i].users > 0) return;
        glDeleteTextures(1, &t);
        sv_image_free(&r->tex_cache[i].img);
        r->tex_cache[i] = r->tex_cache[--r->tex_count];
        return;
    }
    glDeleteTextures(1, &t);
}

sv_status sv_gpu_mesh_upload(sv_renderer *r, const sv_mesh *mesh, sv_gpu_mesh **out, sv_error *err)
{
    *out = NULL;
    if (!r || !mesh) return sv_fail(err, SV_ERR_INTERNAL, "render: upload of a NULL mesh/renderer");
    if (!make_current(r)) return sv_fail(err, SV_ERR_RENDER, "render: OSMesaMakeCurrent failed");
    sv_gpu_mesh *g = calloc(1, sizeof *g);
    if (!g) return sv_fail(err, SV_ERR_NOMEM, "render: out of memory");
    g->r = r;
    g->mesh = mesh;
    double mn[3], mx[3];
    if (sv_mesh_bounds(mesh, mn, mx))
        for (int k = 0; k < 3; k++) g->centre[k] = 0.5 * (mn[k] + mx[k]);

    size_t floats = 0, bytes = 0;
    if (!sv_mul_size(mesh->vertex_count, 8, &floats) ||
        !sv_mul_size(floats, sizeof(float), &bytes) || bytes > (size_t)INT32_MAX * 8) {
        free(g);
        return sv_fail(err, SV_ERR_LIMIT, "render: %u vertices overflow the vertex buffer",
                       mesh->vertex_count);
    }
    float *v = sv_calloc(floats ? floats : 1, sizeof(float));
    if (!v) {
        free(g);
        return sv_fail(err, SV_ERR_NOMEM, "render: out of memory for %u vertices",
                       mesh->vertex_count);
    }
    for (uint32_t i = 0; i < mesh->vertex_count; i++) {
        float *o = v + (size_t)i * 8;
        for (int k = 0; k < 3; k++) {
            o[k] = (float)((double)mesh->positions[3 * (size_t)i + k] - g->centre[k]);
            o[3 + k] = mesh->normals ? mesh->normals[3 * (size_t)i + k] : 0.0f;
        }
        o[6] = mesh->uvs ? mesh->uvs[2 * (size_t)i] : 0.0f;
        o[7] = mesh->uvs ? mesh->uvs[2 * (size_t)i + 1] : 0.0f;
    }
    glGenBuffers(1, &g->vbo);
    glBindBuffer(GL_ARRAY_BUFFER, g->vbo);
    glBufferData(GL_ARRAY_BUFFER, (GLsizeiptr)bytes, v, GL_STATIC_DRAW);
    free(v);

    if (mesh->image_count) {
        g->textures = sv_calloc(mesh->image_count, sizeof(GLuint));
        if (!g->textures) {
            sv_gpu_mesh_free(g);
            return sv_fail(err, SV_ERR_NOMEM, "render: out of memory for textures");
        }
        g->texture_count = mesh->image_count;
        GLint max_tex = 0;
        glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_tex);
        for (uint32_t i = 0; i < mesh->image_count; i++) {
            const sv_image *img = &mesh->images[i];
            if (img->width > (uint32_t)max_tex || img->height > (uint32_t)max_tex) {
                sv_gpu_mesh_free(g);
                return sv_fail(err, SV_ERR_LIMIT,
                               "render: texture %u is %ux%u, over the renderer's %d", i, img->width,
                               img->height, max_tex);
            }
            g->textures[i] = upload_texture(r, img);
        }
    }
    sv_status st = gl_check(err, "mesh upload");
    if (st != SV_OK) {
        sv_gpu_mesh_free(g);
        return st;
    }
    *out = g;
    return SV_OK;
}

void sv_gpu_mesh_free(sv_gpu_mesh *g)
{
    if (!g) return;
    if (make_current(g->r)) {
        if (g->vbo) glDeleteBuffers(1, &g->vbo);
        for (uint32_t i = 0; i < g->texture_count; i++)
            if (g->textures[i]) release_texture(g->r, g->textures[i]);
    }
    free(g->textures);
    free(g);
}

static sv_status ensure_fbo(sv_renderer *r, uint32_t w, uint32_t h, sv_error *err)
{
    if (w <= r->fb_w && h <= r->fb_h) return SV_OK;
    uint32_t nw = w > r->fb_w ? w : r->fb_w, nh = h > r->fb_h ? h : r->fb_h;
    glBindFramebuffer(GL_FRAMEBUFFER, r->fbo);
    glBindRenderbuffer(GL_RENDERBUFFER, r->rb_color);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, (GLsizei)nw, (GLsizei)nh);
    glBindRenderbuffer(GL_RENDERBUFFER, r->rb_color16);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA16, (GLsizei)nw, (GLsizei)nh);
    glBindRenderbuffer(GL_RENDERBUFFER, r->rb_depth);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT32F, (GLsizei)nw, (GLsizei)nh);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, r->rb_depth);
    GLenum fs = GL_FRAMEBUFFER_COMPLETE;
    for (int k = 0; k < 2 && fs == GL_FRAMEBUFFER_COMPLETE; k++) {
        glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER,
                                  k ? r->rb_color : r->rb_color16);
        fs = glCheckFramebufferStatus(GL_FRAMEBUFFER);
    }
    if (fs != GL_FRAMEBUFFER_COMPLETE) {
        r->fb_w = r->fb_h = 0;
        return sv_fail(err, SV_ERR_RENDER, "render: framebuffer %ux%u incomplete (0x%x)", nw, nh,
                       (unsigned)fs);
    }
    r->fb_w = nw;
    r->fb_h = nh;
    return gl_check(err, "framebuffer allocation");
}

/* Groups the triangles to draw by material (stable: each material's triangles
 * keep their order), writes their indices to idx and the per-material start
 * (in triangles) to start[0..material_count]. */
static void group_by_material(const sv_mesh *m, const uint32_t *tris, uint32_t n, uint32_t *idx,
                              uint32_t *start)
{
    uint32_t mc = m->material_count;
    memset(start, 0, (mc + 1) * sizeof *start);
    for (uint32_t i = 0; i < n; i++) {
        uint32_t t = tris ? tris[i] : i;
        uint32_t mat = m->tri_material ? m->tri_material[t] : 0;
        start[(mat < mc ? mat : 0) + 1]++;
    }
    for (uint32_t k = 0; k < mc; k++) start[k + 1] += start[k];
    uint32_t *fill = start + mc + 1; /* scratch of mc entries after start */
    memcpy(fill, start, mc * sizeof *fill);
    for (uint32_t i = 0; i < n; i++) {
        uint32_t t = tris ? tris[i] : i;
        uint32_t mat = m->tri_material ? m->tri_material[t] : 0;
        if (mat >= mc) mat = 0;
        uint32_t at = fill[mat]++;
        memcpy(idx + 3 * (size_t)at, m->indices + 3 * (size_t)t, 3 * sizeof(uint32_t));
    }
}

/* Reads the RGBA16 colour buffer into *color (allocated here, row 0 at the
 * top): RGBA16 as stored when linear, else RGBA8 with R, G, B encoded by
 * the sRGB OETF and alpha rounded to 8 bits. */
static sv_status read_color16(sv_renderer *r, uint32_t width, uint32_t height, bool linear,
                              sv_image *color, sv_error *err)
{
    size_t npx = (size_t)width * height;
    uint16_t *px = scratch((void **)&r->rb16, &r->rb16_cap, npx * 4, sizeof *px);
    if (!px)
        return sv_fail(err, SV_ERR_NOMEM, "render: out of memory for a %ux%u read-back", width,
                       height);
    glReadPixels(0, 0, (GLsizei)width, (GLsizei)height, GL_RGBA, GL_UNSIGNED_SHORT, px);
    sv_status st = sv_image_alloc(color, width, height, 4, linear ? 16 : 8, err);
    if (st != SV_OK) return st;
    size_t row = (size_t)width * 4;
    const uint8_t *enc = linear ? NULL : sv_srgb_encode16_table();
    for (uint32_t y = 0; y < height; y++) {
        const uint16_t *src = px + (size_t)(r->pack_invert ? y : height - 1 - y) * row;
        if (linear) {
            memcpy((uint16_t *)color->data + (size_t)y * row, src, row * sizeof *src);
            continue;
        }
        uint8_t *dst = (uint8_t *)color->data + (size_t)y * row;
        for (size_t i = 0; i < row; i += 4) {
            for (int k = 0; k < 3; k++) dst[i + k] = enc[src[i + k]];
            dst[i + 3] = (uint8_t)((src[i + 3] * 255u + 32767u) / 65535u);
        }
    }
    return SV_OK;
}

sv_status sv_render(sv_renderer *r, const sv_gpu_mesh *g, const uint32_t *tris, uint32_t tri_count,
                    const sv_camera *cam, const sv_render_options *opt, uint32_t width,
                    uint32_t height, sv_image *color, float *depth, sv_error *err)
{
    if (color) memset(color, 0, sizeof *color);
    if (!r || !g || !cam)
        return sv_fail(err, SV_ERR_INTERNAL, "render: NULL renderer, mesh or camera");
    if (width == 0 || height == 0 || width > r->max_size || height > r->max_size)
        return sv_fail(err, SV_ERR_LIMIT, "render: target %ux%u outside 1..%u", width, height,
                       r->max_size);
    if (!(cam->half_width > 0) || !(cam->half_height > 0) || !isfinite(cam->near_dist) ||
        !isfinite(cam->far_dist))
        return sv_fail(err, SV_ERR_INTERNAL, "render: degenerate camera (half %g x %g)",
                       cam->half_width, cam->half_height);
    const sv_mesh *m = g->mesh;
    if (!tris) tri_count = m->triangle_count;
    for (uint32_t i = 0; tris && i < tri_count; i++)
        if (tris[i] >= m->triangle_count)
            return sv_fail(err, SV_ERR_INTERNAL, "render: triangle %u out of range (%u)", tris[i],
                           m->triangle_count);
    sv_render_options dflt = {0};
    if (!opt) opt = &dflt;
    if (!make_current(r)) return sv_fail(err, SV_ERR_RENDER, "render: OSMesaMakeCurrent failed");
    sv_status st = ensure_fbo(r, width, height, err);
    if (st != SV_OK) return st;

    /* Camera: eye frame x = right, y = up, z = back = -forward (right-handed). */
    double fwd[3];
    sv_camera_forward(cam, fwd);
    const double *R = cam->right, *U = cam->up;
    double B[3] = {-fwd[0], -fwd[1], -fwd[2]};
    double nearv = cam->near_dist, farv = cam->far_dist;
    if (!(farv > nearv)) {
        double e = 1e-6 * (fabs(nearv) + 1.0);
        nearv -= e;
        farv += e;
    }
    double o[3] = {cam->origin[0] - g->centre[0], cam->origin[1] - g->centre[1],
                   cam->origin[2] - g->centre[2]};
    double sx = 1.0 / cam->half_width, sy = 1.0 / cam->half_height;
    /* z_ndc = (2 dist - (n+f)) / (f-n), dist = -(eye z) = (p-o)·fwd */
    double sz = 2.0 / (farv - nearv), tz = -(farv + nearv) / (farv - nearv);
    double rows[4][4];
    for (int k = 0; k < 3; k++) {
        rows[0][k] = sx * R[k];
        rows[1][k] = sy * U[k];
        rows[2][k] = sz * fwd[k];
        rows[3][k] = 0.0;
    }
    rows[0][3] = -sx * (R[0] * o[0] + R[1] * o[1] + R[2] * o[2]);
    rows[1][3] = -sy * (U[0] * o[0] + U[1] * o[1] + U[2] * o[2]);
    rows[2][3] = -sz * (fwd[0] * o[0] + fwd[1] * o[1] + fwd[2] * o[2]) + tz;
    rows[3][3] = 1.0;
    GLfloat mvp[16], ncam[9], light[3];
    for (int c = 0; c < 4; c++)
        for (int rr = 0; rr < 4; rr++) mvp[c * 4 + rr] = (GLfloat)rows[rr][c]; /* column-major */
    for (int c = 0; c < 3; c++) {
        ncam[c * 3 + 0] = (GLfloat)R[c];
        ncam[c * 3 + 1] = (GLfloat)U[c];
        ncam[c * 3 + 2] = (GLfloat)B[c];
    }
    const double *L = opt->light_dir;
    light[0] = (GLfloat)(L[0] * R[0] + L[1] * R[1] + L[2] * R[2]);
    light[1] = (GLfloat)(L[0] * U[0] + L[1] * U[1] + L[2] * U[2]);
    light[2] = (GLfloat)(L[0] * B[0] + L[1] * B[1] + L[2] * B[2]);

    /* colour shades in 16 bits (linear, encoded on read-back), the others as before */
    bool wide = opt->shade == SV_SHADE_ALBEDO || opt->shade == SV_SHADE_LIT;
    glBindFramebuffer(GL_FRAMEBUFFER, r->fbo);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER,
                              wide ? r->rb_color16 : r->rb_color);
    glViewport(0, 0, (GLsizei)width, (GLsizei)height);
    glEnable(GL_SCISSOR_TEST);
    glScissor(0, 0, (GLsizei)width, (GLsizei)height);
    glClearColor(0, 0, 0, 0);
    glClearDepth(1.0);
    glDepthMask(GL_TRUE);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);

    if (tri_count > 0 && m->material_count > 0) {
        uint32_t mc = m->material_count;
        size_t idx_n = 0, idx_bytes = 0;
        uint32_t *idx = NULL, *start = NULL;
        if (sv_mul_size(tri_count, 3, &idx_n) && sv_mul_size(idx_n, 4, &idx_bytes)) {
            idx = scratch((void **)&r->idx, &r->idx_cap, idx_n, sizeof *idx);
            start = sv_calloc(2 * (size_t)mc + 1, sizeof *start);
        }
        if (!idx || !start) {
            free(start);
            return sv_fail(err, SV_ERR_NOMEM, "render: out of memory for %u triangles", tri_count);
        }
        group_by_material(m, tris, tri_count, idx, start);
        bool amax = opt->shade == SV_SHADE_ALPHA_MAX;
        const struct gl_prog *P = opt->shade == SV_SHADE_ALBEDO || amax ? &r->albedo : &r->full;
        if (amax) { /* the largest alpha of any fragment, whatever its depth */
            glDisable(GL_DEPTH_TEST);
            glEnable(GL_BLEND);
            glBlendEquation(GL_MAX);
        }
        glUseProgram(P->id);
        glBindBuffer(GL_ARRAY_BUFFER, g->vbo);
        glEnableVertexAttribArray(0);
        if (P->normals) glEnableVertexAttribArray(1);
        glEnableVertexAttribArray(2);
        glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 32, (const void *)0);
        glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 32, (const void *)12);
        glVertexAttribPointer(2, 2, GL_FLOAT, GL_FALSE, 32, (const void *)24);
        glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, r->ibo);
        glBufferData(GL_ELEMENT_ARRAY_BUFFER, (GLsizeiptr)idx_bytes, idx, GL_STREAM_DRAW);
        glUniformMatrix4fv(P->u_mvp, 1, GL_FALSE, mvp);
        glUniformMatrix3fv(P->u_ncam, 1, GL_FALSE, ncam);
        glUniform1i(P->u_shade, opt->shade == SV_SHADE_NORMAL ? 1
                                : opt->shade == SV_SHADE_LIT  ? 2
                                                              : 0);
        glUniform3fv(P->u_light, 1, light);
        glUniform1f(P->u_ambient, (GLfloat)(opt->ambient > 0 ? opt->ambient : 0.35));
        glUniform1i(P->u_tex, 0);
        glActiveTexture(GL_TEXTURE0);
        for (uint32_t k = 0; k < mc; k++) {
            uint32_t n = start[k + 1] - start[k];
            if (n == 0) continue;
            const sv_material *mat = &m->materials[k];
            GLuint tex = 0;
            if (mat->base_texture >= 0 && (uint32_t)mat->base_texture < g->texture_count)
                tex = g->textures[mat->base_texture];
            glBindTexture(GL_TEXTURE_2D, tex);
            glUniform1i(P->u_has_tex, tex != 0);
            glUniform4f(P->u_base, mat->base_color[0], mat->base_color[1], mat->base_color[2],
                        mat->base_color[3]);
            float cutoff = -1.0f;
            if (mat->alpha_mode == SV_ALPHA_MASK) cutoff = mat->alpha_cutoff;
            else if (mat->alpha_mode == SV_ALPHA_BLEND) cutoff = 0.5f;
            if (amax && mat->alpha_mode == SV_ALPHA_MASK && mat->alpha_cutoff == 0.0f)
                cutoff = -2.0f; /* swept: its alpha, untested */
            glUniform1f(P->u_cutoff, cutoff);
            /* baked-lit materials are not lit twice */
            if (opt->shade == SV_SHADE_LIT) glUniform1i(P->u_shade, mat->unlit ? 0 : 2);
            glDrawElements(GL_TRIANGLES, (GLsizei)(3 * n), GL_UNSIGNED_INT,
                           (const void *)((size_t)start[k] * 3 * sizeof(uint32_t)));
        }
        free(start);
        glDisableVertexAttribArray(0);
        glDisableVertexAttribArray(1);
        glDisableVertexAttribArray(2);
        glBindBuffer(GL_ARRAY_BUFFER, 0);
        glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, 0);
        glBindTexture(GL_TEXTURE_2D, 0);
        glUseProgram(0);
        if (amax) {
            glBlendEquation(GL_FUNC_ADD);
            glDisable(GL_BLEND);
            glEnable(GL_DEPTH_TEST);
        }
    }
    glFinish();
    st = gl_check(err, "drawing");
    if (st != SV_OK) return st;

    size_t npx = (size_t)width * height; /* both <= max_size <= 16384: no overflow */
    if (color && wide) {
        st = read_color16(r, width, height, opt->linear, color, err);
        if (st != SV_OK) return st;
    } else if (color) {
        st = sv_image_alloc(color, width, height, 4, 8, err);
        if (st != SV_OK) return st;
        uint8_t *px = color->data;
        glReadPixels(0, 0, (GLsizei)width, (GLsizei)height, GL_RGBA, GL_UNSIGNED_BYTE, px);
        /* GL's row 0 is the bottom: flip so row 0 is the top (unless
         * GL_MESA_pack_invert already did). */
        size_t stride = (size_t)width * 4;
        uint8_t *tmp = r->pack_invert ? NULL : malloc(stride);
        if (!r->pack_invert && !tmp) {
            sv_image_free(color);
            return sv_fail(err, SV_ERR_NOMEM, "render: out of memory");
        }
        for (uint32_t y = 0; tmp && y < height / 2; y++) {
            uint8_t *a = px + y * stride, *b = px + (height - 1 - y) * stride;
            memcpy(tmp, a, stride);
            memcpy(a, b, stride);
            memcpy(b, tmp, stride);
        }
        free(tmp);
    }
    if (depth) {
        /* window depth in [0, 1] -> distance along forward; 1 (cleared) = nothing drawn */
        double span = farv - nearv;
        float *zb = depth; /* top row first: convert in place */
        if (!r->pack_invert && !(zb = malloc(npx * sizeof(float)))) {
            if (color) sv_image_free(color);
            return sv_fail(err, SV_ERR_NOMEM, "render: out of memory for depth");
        }
        glReadPixels(0, 0, (GLsizei)width, (GLsizei)height, GL_DEPTH_COMPONENT, GL_FLOAT, zb);
        for (uint32_t y = 0; y < height; y++) {
            const float *src = zb + (size_t)(r->pack_invert ? y : height - 1 - y) * width;
            float *dst = depth + (size_t)y * width;
            for (uint32_t x = 0; x < width; x++)
                dst[x] = src[x] >= 1.0f ? INFINITY : (float)(nearv + (double)src[x] * span);
        }
        if (zb != depth) free(zb);
    }
    st = gl_check(err, "read back");
    if (st != SV_OK && color) sv_image_free(color);
    return st;
}

#if defined(__SANITIZE_ADDRESS__)
/* LeakSanitizer's built-in suppressions for any sanitizer build that renders:
 * Mesa/llvmpipe keep process-lifetime allocations that are not ours. Built in
 * (not only in tests/lsan.supp) because the daemon starts workers with a clean
 * environment. Our own code gets no suppressions. */
const char *__lsan_default_suppressions(void);
const char *__lsan_default_suppressions(void)
{
    return "leak:libOSMesa\nleak:libLLVM\nleak:libgallium\nleak:swrast_dri\nleak:libglapi\n";
}
#endif
