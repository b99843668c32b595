/* scene.c — scene defaults and the screen-size ⇄ distance conversion used to
 * plan LODs (perspective camera: pixels = h / (2 d tan(fov/2)) × screen_height). */
#include "scene.h"

#include <math.h>

void sv_scene_defaults(sv_scene *s)
{
    s->lighting = SV_LIGHTING_UNLIT;
    /* From above and in front, normalised (0.3, 0.8, 0.5). */
    double l = sqrt(0.3 * 0.3 + 0.8 * 0.8 + 0.5 * 0.5);
    s->light_dir[0] = 0.3 / l;
    s->light_dir[1] = 0.8 / l;
    s->light_dir[2] = 0.5 / l;
    s->shadows = false;
    s->ambient_occlusion = false;
    s->viewer = SV_VIEWER_SIDE;
    s->distance_min = 10.0;
    s->distance_max = 1000.0; /* an open-world draw distance: nearer, a tree is
                               * too tall for any quad level to be drawn */
    s->distance_auto = true;  /* replaced by the tree's own range once its size is
                               * known: a bake does not depend on the file's units */
    s->screen_height = 1080;
    s->fov_y_deg = 60.0;
    s->camera_speed = 0.0;
}

void sv_viewer_band(sv_viewer v, double *lo_deg, double *hi_deg, bool *by_angle)
{
    double lo = -90, hi = 90; /* ORBIT: the whole sphere */
    bool angle = false;
    if (v == SV_VIEWER_SIDE) lo = -10, hi = 40, angle = true;
    else if (v == SV_VIEWER_GROUND) lo = 0, hi = 20;
    else if (v == SV_VIEWER_AERIAL) lo = 40, hi = 90;
    *lo_deg = lo;
    *hi_deg = hi;
    *by_angle = angle;
}

double sv_scene_pixels(const sv_scene *s, double h, double dist)
{
    double t = tan(0.5 * s->fov_y_deg * M_PI / 180.0);
    if (dist <= 0 || t <= 0) return INFINITY;
    return h / (2.0 * dist * t) * (double)s->screen_height;
}

double sv_scene_distance_for_pixels(const sv_scene *s, double h, double pixels)
{
    double t = tan(0.5 * s->fov_y_deg * M_PI / 180.0);
    if (pixels <= 0 || t <= 0) return INFINITY;
    return h * (double)s->screen_height / (2.0 * t * pixels);
}

void sv_scene_resolve_distance(sv_scene *s, double h)
{
    if (!s->distance_auto || !(h > 0) || !isfinite(h)) return;
    double d = sv_scene_distance_for_pixels(s, h, (double)s->screen_height);
    if (!(d > 0) || !isfinite(d)) return;
    s->distance_min = d;
    s->distance_max = d * SV_SCENE_AUTO_RANGE;
}
