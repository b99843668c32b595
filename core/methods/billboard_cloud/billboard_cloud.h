/* billboard_cloud.h — the billboard clouds' own declarations, shared by
 * the schema half (billboard_cloud_settings.c) and the build half
 * (billboard_cloud.c); nothing outside its folder includes it but tests. */
#ifndef SV_BILLBOARD_CLOUD_H
#define SV_BILLBOARD_CLOUD_H

#include "method.h"
#include "method_ops.h"

#define BC_NAME "billboard_cloud"
#define BC_MAX_LODS 8
#define BC_DEFAULT_EPS 0.14
#define BC_DEFAULT_MAX 24

/* trunk_max_triangles when not given (the coarser LODs' budget) */
#define BC_TRUNK_MAX_DEFAULT 200

typedef struct bc_lod {
    double epsilon;  /* fraction of R; 0 = from the previous LOD / the default */
    long max_planes; /* 0 = no limit */
} bc_lod;

typedef struct bc_settings {
    double epsilon;
    long max_planes;
    bc_lod lods[BC_MAX_LODS];
    int lod_count;
    long grid[3];
    int hp_enabled; /* -1 auto */
    double hp_penalty, hp_angle;
    bool cb_enabled;
    double cb_coverage;
    bool tweak, weld;
    long threads;
    double miss_penalty, max_angle;
    long refine;
    bool trunk_mesh;
    long trunk_max[BC_MAX_LODS];
} bc_settings;

/* The settings object s (NULL: defaults) into o; SV_ERR_SPEC naming the key. */
sv_status bc_parse(const cJSON *s, bc_settings *o, sv_error *err);

extern const sv_method sv_method_billboard_cloud;
extern const sv_method_ops sv_method_billboard_cloud_ops;

#endif
