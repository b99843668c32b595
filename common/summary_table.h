/* summary_table.h — the table that ends a bake on stdout, the same from
 * sylva-bake (core/cli) and from the `sylva` client (client/sylva.c), read
 * from the bake's report.json (docs/outputs.md):
 *
 *   level          triangles     texels  switch px  IoU@64  file
 *   full                3616          0       1080   0.982  lod0_full.glb
 *
 * switch px: the tree's height on screen, in pixels, where the level starts
 * being drawn (report.json lods[].switch_pixels); IoU@64: the silhouette IoU
 * against the source at 64 px (lods[].accuracy, pixels 64, iou_mean),
 * truncated (not rounded) to 3 decimals; "-" when the report lacks a value.
 *
 * Header-only (static): the client links nothing of core.
 */
#ifndef SYLVA_SUMMARY_TABLE_H
#define SYLVA_SUMMARY_TABLE_H

#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>

/* Prints the table of report (a parsed report.json) on out, with "DIR/" before
 * each file name when dir is not NULL. Returns the number of levels printed
 * (0, and nothing printed, when report has no "lods" array). */
static inline int sylva_summary_table(const cJSON *report, const char *dir, FILE *out)
{
    const cJSON *lods = cJSON_GetObjectItemCaseSensitive(report, "lods"), *l;
    if (!cJSON_IsArray(lods) || cJSON_GetArraySize(lods) == 0) return 0;
    fprintf(out, "%-16s %10s %10s %10s %7s  %s\n", "level", "triangles", "texels", "switch px",
            "IoU@64", "file");
    int n = 0;
    cJSON_ArrayForEach(l, lods)
    {
        const char *name = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(l, "name"));
        const char *file = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(l, "file"));
        const cJSON *tri = cJSON_GetObjectItemCaseSensitive(l, "triangles");
        const cJSON *tex = cJSON_GetObjectItemCaseSensitive(l, "texels");
        const cJSON *sw = cJSON_GetObjectItemCaseSensitive(l, "switch_pixels");
        char c_tri[24] = "-", c_tex[24] = "-", c_sw[24] = "-", c_iou[16] = "-";
        if (cJSON_IsNumber(tri)) snprintf(c_tri, sizeof c_tri, "%.0f", tri->valuedouble);
        if (cJSON_IsNumber(tex)) snprintf(c_tex, sizeof c_tex, "%.0f", tex->valuedouble);
        if (cJSON_IsNumber(sw)) snprintf(c_sw, sizeof c_sw, "%.0f", sw->valuedouble);
        const cJSON *a;
        cJSON_ArrayForEach(a, cJSON_GetObjectItemCaseSensitive(l, "accuracy"))
        {
            const cJSON *px = cJSON_GetObjectItemCaseSensitive(a, "pixels");
            const cJSON *iou = cJSON_GetObjectItemCaseSensitive(a, "iou_mean");
            if (cJSON_IsNumber(px) && px->valuedouble == 64 && cJSON_IsNumber(iou))
                snprintf(c_iou, sizeof c_iou, "%.3f", floor(iou->valuedouble * 1000.0) / 1000.0);
        }
        fprintf(out, "%-16s %10s %10s %10s %7s  %s%s%s\n", name ? name : "?", c_tri, c_tex, c_sw,
                c_iou, dir && file ? dir : "", dir && file ? "/" : "", file ? file : "-");
        n++;
    }
    return n;
}

#endif
