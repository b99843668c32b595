/* out_names.h - the names a bake writes into its output folder, shared by
 * sylva-bake (core/cli) and libsylva (client/) so both clean the same files
 * out of a reused --out folder: model.glb, planes.json,
 * report.json, preview.png, impostor.json, error.json, lod<i>_<name>.glb,
 * atlas_<level>_<map>.png, the LOD group files lods.glb, lods.fbx,
 * lod<i>_<name>.fbx and their textures tex_<16 hex digits>.png|jpg
 * (docs/outputs.md). Header-only: the client links
 * nothing of core.
 */
#ifndef SYLVA_OUT_NAMES_H
#define SYLVA_OUT_NAMES_H

#include <stdbool.h>
#include <string.h>

/* True when name (a base name) is one a bake writes: such a file in an
 * output folder belongs to sylva and may be replaced or removed. */
static inline bool sylva_is_output_name(const char *name)
{
    static const char *const fixed[] = {"model.glb",   "planes.json",   "report.json",
                                        "preview.png", "impostor.json", "error.json",
                                        "lods.glb",    "lods.fbx"};
    for (size_t i = 0; i < sizeof fixed / sizeof fixed[0]; i++)
        if (strcmp(name, fixed[i]) == 0) return true;
    size_t n = strlen(name);
    if (strchr(name, '/')) return false;
    if (n > 10 && strncmp(name, "atlas_", 6) == 0 && strcmp(name + n - 4, ".png") == 0) return true;
    if (n == 24 && strncmp(name, "tex_", 4) == 0 &&
        (strcmp(name + 20, ".png") == 0 || strcmp(name + 20, ".jpg") == 0))
        return strspn(name + 4, "0123456789abcdef") == 16;
    if (n > 7 && strncmp(name, "lod", 3) == 0 &&
        (strcmp(name + n - 4, ".glb") == 0 || strcmp(name + n - 4, ".fbx") == 0)) {
        const char *p = name + 3;
        if (*p < '0' || *p > '9') return false;
        while (*p >= '0' && *p <= '9') p++;
        return *p == '_';
    }
    return false;
}

#endif
