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
typedef enum sv_lighting {
    SV_LIGHTING_STATIC = 0,
    SV_LIGHTING_DYNAMIC,
    SV_LIGHTING_UNLIT
} sv_lighting;
/* SIDE (the default): a helix of views from -10° to 40° elevation, the views
 * trees are seen from and the ones ../shared/tools/sveval judges by;
 * ORBIT: the whole sphere; GROUND: 0..20°; AERIAL: 40..90°. */
typedef enum sv_viewer {
    SV_VIEWER_ORBIT = 0,
    SV_VIEWER_GROUND,
    SV_VIEWER_AERIAL,
    SV_VIEWER_SIDE
} sv_viewer;

/* The viewer's band of elevations above: [*lo_deg, *hi_deg] in degrees, and
 * *by_angle true when its views are even in angle (SIDE), else in sin(e). */
void sv_viewer_band(sv_viewer v, double *lo_deg, double *hi_deg, bool *by_angle);

typedef struct sv_scene {
    sv_lighting lighting;
    double light_dir[3];    /* unit, towards the light (static lighting) */
    bool shadows;           /* depth maps */
    bool ambient_occlusion; /* AO maps (dynamic lighting only) */
    sv_viewer viewer;
    double distance_min; /* metres from the camera to the tree */
    double distance_max;
    bool distance_auto;     /* true (the default, or "distance": "auto"): the
                                * distances follow the tree's size once it is
                                * known (sv_scene_resolve_distance) */
    uint32_t screen_height; /* pixels */
    double fov_y_deg;       /* vertical field of view */
    double camera_speed;    /* m/s; > 0 enables Cook's motion term */
} sv_scene;

/* The automatic distance range: from where the tree fills the screen's
 * height to where it is SV_SCENE_AUTO_RANGE times smaller (1080 px down to
 * 10.8 px on the default screen; [10.4, 1039] m for a 12 m tree). */
#define SV_SCENE_AUTO_RANGE 100.0

/* Fills the defaults listed above (distance_auto true, with [10, 1000] m as
 * the range until sv_scene_resolve_distance replaces it). */
void sv_scene_defaults(sv_scene *s);

/* With distance_auto, sets [distance_min, distance_max] from the tree's size
 * h (world units, the height screen sizes are measured on): the distance at
 * which h is screen_height pixels tall, and SV_SCENE_AUTO_RANGE times that.
 * No change when distance_auto is false or h is not a positive number. */
void sv_scene_resolve_distance(sv_scene *s, double h);

/* Height in pixels of an object of world height h seen at distance dist. */
double sv_scene_pixels(const sv_scene *s, double h, double dist);

/* Distance at which an object of world height h is `pixels` tall. */
double sv_scene_distance_for_pixels(const sv_scene *s, double h, double pixels);

#endif
