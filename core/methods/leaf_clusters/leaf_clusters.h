/* leaf_clusters.h — the leaf clusters' own declarations, shared by the
 * schema half (leaf_clusters_settings.c) and the build half
 * (leaf_clusters.c); nothing outside its folder includes it but tests. */
#ifndef SV_LEAF_CLUSTERS_H
#define SV_LEAF_CLUSTERS_H

#include "method.h"
#include "method_ops.h"

#define LC_NAME "leaf_clusters"
#define LC_MAX_LEVELS 8
#define LC_MAX_CLUSTERS 1024

/* trunk_max_triangles when not given (the coarser LODs' budget) */
#define LC_TRUNK_MAX_DEFAULT 200

typedef struct lc_settings {
    uint32_t levels[LC_MAX_LEVELS];
    uint32_t level_count;
    double alpha_rel;
    bool area_weighted;
    long iterations;
    long seed_tries;
    double trunk_ratio[LC_MAX_LEVELS];
    long trunk_max[LC_MAX_LEVELS];
    bool twigs;
} lc_settings;

/* The settings object s (NULL: defaults) into o; SV_ERR_SPEC naming the key. */
sv_status lc_parse(const cJSON *s, lc_settings *o, sv_error *err);

extern const sv_method sv_method_leaf_clusters;
extern const sv_method_ops sv_method_leaf_clusters_ops;

#endif
