/* render.h — "draw these triangles of this mesh with this camera into this image".
 *
 * The only backend today is core/render/render_osmesa.c (OSMesa, Mesa llvmpipe), the one
 * file in sylva that includes GL headers. Another backend (EGL surfaceless) can
 * replace that one file. Contexts are created in the process that bakes (the
 * sylva-bake worker), never in the daemon.
 *
 * Rendering is faithful to the source material: base colour × texture as
 * glTF defines them (the factor linear, an 8-bit texture sRGB-encoded and
 * decoded before filtering; image.h), multiplied in linear, alpha
 * MASK cutoff honoured (BLEND is rendered as MASK with cutoff 0.5: baked
 * textures must have binary alpha), two-sided, depth tested. Output is
 * deterministic (fixed rasteriser thread count, cleared buffers).
 *
 * Cameras are orthographic. Image +x is `right`, image +y is `up` (row 0 of the
 * output image is the TOP row), and the camera looks along forward = up × right.
 */
#ifndef SV_RENDER_H
#define SV_RENDER_H

#include "mesh.h"

typedef struct sv_camera {
    double origin[3];   /* world point at the image centre */
    double right[3];    /* unit */
    double up[3];       /* unit, orthogonal to right */
    double half_width;  /* world units from centre to left/right edge */
    double half_height; /* world units from centre to top/bottom edge */
    double near_dist; /* clip: keep points with near <= (p-origin)·forward <= far; may be negative */
    double far_dist;
} sv_camera;

typedef enum sv_shade {
    SV_SHADE_ALBEDO = 0, /* RGBA = base colour × texture, unlit (linear product) */
    SV_SHADE_NORMAL,     /* RGB = 0.5 + 0.5 n in camera frame (x=right, y=up, z=toward camera),
                             n facing the camera for two-sided faces; A = coverage */
    SV_SHADE_LIT,        /* albedo × (ambient + diffuse) from `light_dir` (static lighting) */
    SV_SHADE_ALPHA_MAX   /* A = the largest alpha any fragment drew at the pixel, no depth
                            test: MASK materials with alpha_cutoff 0 ("swept") draw their
                            alpha (base × texture) untested, every other fragment that passes
                            its own test draws 1. A pixel's A is at least k + 1 (k in 0..254)
                            exactly when the mesh drawn with the swept cutoffs at
                            (k + 0.5) / 255 covers it: one render for every cutoff
                            (calibrate.c). RGB unspecified. */
} sv_shade;

typedef struct sv_render_options {
    sv_shade shade;
    double light_dir[3]; /* SV_SHADE_LIT: unit direction towards the light, world space */
    double ambient;      /* SV_SHADE_LIT: ambient term, default 0 means 0.35 */
    bool linear;         /* SV_SHADE_ALBEDO and SV_SHADE_LIT: colour is RGBA16 with linear
                            R, G, B (for code that filters or accumulates colour); false:
                            RGBA8 with R, G, B sRGB-encoded (exact OETF), the colour a
                            glTF viewer shows. The other shades always give RGBA8. */
} sv_render_options;

typedef struct sv_renderer sv_renderer;
typedef struct sv_gpu_mesh sv_gpu_mesh;

/* Creates an offscreen renderer able to draw up to max_size × max_size pixels
 * (framebuffer objects). Fails with SV_ERR_RENDER if no context can be made. */
sv_status sv_renderer_create(uint32_t max_size, sv_renderer **out, sv_error *err);
void sv_renderer_destroy(sv_renderer *r);

/* Largest target side sv_render accepts: the max_size asked for at creation,
 * lowered to what the GL implementation supports. 0 for NULL. */
uint32_t sv_renderer_max_size(const sv_renderer *r);

/* Uploads a mesh (vertices, indices, textures) once for many draws. The mesh
 * must outlive the handle. */
sv_status sv_gpu_mesh_upload(sv_renderer *r, const sv_mesh *mesh, sv_gpu_mesh **out, sv_error *err);
void sv_gpu_mesh_free(sv_gpu_mesh *g);

/* Draws triangles `tris[0..tri_count)` of the uploaded mesh (all triangles when
 * tris is NULL) into a width × height target cleared to transparent black.
 * color (may be NULL) receives RGBA8, or RGBA16 when opt->linear asks for it
 * (allocated by the call; caller frees with sv_image_free). depth (may be NULL) receives width*height floats: distance
 * along forward from the camera origin plane, or INFINITY where nothing was drawn. */
sv_status sv_render(sv_renderer *r, const sv_gpu_mesh *g, const uint32_t *tris, uint32_t tri_count,
                    const sv_camera *cam, const sv_render_options *opt, uint32_t width,
                    uint32_t height, sv_image *color, float *depth, sv_error *err);

/* forward = up × right for the camera. */
void sv_camera_forward(const sv_camera *cam, double fwd[3]);

#endif
