/* scene.h — how the asset will be seen; decides which effects are simulated.
 * Parsed from the spec's "scene" object (see docs/spec.md). Defaults (zeroed
 * struct passed through sv_scene_defaults): static lighting from above-front,
 * no shadows, no AO, orbit viewer, distances 10–200 m, 1080-pixel screen,
 * 60° vertical field of view, no camera motion.
 */
#ifndef SV_SCENE_H
#define SV_SCENE_H

#include "sv.h"

/* STATIC: light baked into the albedo; DYNAMIC: unlit albedo + normal map;
 * UNLIT (the default): albedo as the material shows it, no light, no normal map
 * (what an engine lights itself, and what does not pop at a LOD switch). */
typedef enum sv_lighting { SV_LIGHTING_STATIC = 0, SV_LIGHTING_DYNAMIC, SV_LIGHTING_UNLIT } sv_lighting;
/* SIDE (the default): a helix of views from -10° to 40° elevation, the views
 * trees are seen from and the ones ../shared/tools/sveval judges by;
 * ORBIT: the whole sphere; GROUND: 0..20°; AERIAL: 40..90°. */
typedef enum sv_viewer { SV_VIEWER_ORBIT = 0, SV_VIEWER_GROUND, SV_VIEWER_AERIAL, SV_VIEWER_SIDE } sv_viewer;

typedef struct sv_scene {
    sv_lighting lighting;
    double light_dir[3];       /* unit, towards the light (static lighting) */
    bool shadows;              /* depth maps */
    bool ambient_occlusion;    /* AO maps (dynamic lighting only) */
    sv_viewer viewer;
    double distance_min;       /* metres from the camera to the tree */
    double distance_max;
    uint32_t screen_height;    /* pixels */
    double fov_y_deg;          /* vertical field of view */
    double camera_speed;       /* m/s; > 0 enables Cook's motion term */
} sv_scene;

/* Fills the defaults listed above. */
void sv_scene_defaults(sv_scene *s);

/* Height in pixels of an object of world height h seen at distance dist. */
double sv_scene_pixels(const sv_scene *s, double h, double dist);

/* Distance at which an object of world height h is `pixels` tall. */
double sv_scene_distance_for_pixels(const sv_scene *s, double h, double pixels);

#endif
