/* preview.c — the chain preview (preview.h). Text with stb_easy_font's
 * axis-aligned quads, filled as rectangles. */
#include "preview.h"
#include "image_io.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wconversion"
#include <stb_easy_font.h>
#pragma GCC diagnostic pop

#define BG 96
#define LINE 11
#define LINES 5

/* Draws an RGBA render (alpha = coverage) of size s at (x, y) over the grey. */
static void blit(sv_image *c, const sv_image *src, uint32_t x, uint32_t y)
{
    for (uint32_t j = 0; j < src->height && y + j < c->height; j++)
        for (uint32_t i = 0; i < src->width && x + i < c->width; i++) {
            const uint8_t *s = (const uint8_t *)src->data + 4 * ((size_t)j * src->width + i);
            uint8_t *d = (uint8_t *)c->data + 3 * ((size_t)(y + j) * c->width + x + i);
            for (int k = 0; k < 3; k++)
                d[k] = (uint8_t)((s[k] * s[3] + BG * (255 - s[3]) + 127) / 255);
        }
}

static void text(sv_image *c, int x, int y, const char *s)
{
    static char buf[64 * 1024];
    unsigned char col[4] = {255, 255, 255, 255};
    int quads = stb_easy_font_print((float)x, (float)y, (char *)s, col, buf, sizeof buf);
    for (int q = 0; q < quads; q++) {
        const float *v = (const float *)(buf + 64 * q); /* 4 vertices × 16 bytes */
        int x0 = (int)v[0], y0 = (int)v[1], x1 = (int)v[8], y1 = (int)v[9];
        for (int yy = y0; yy < y1; yy++)
            for (int xx = x0; xx < x1; xx++)
                if (xx >= 0 && yy >= 0 && (uint32_t)xx < c->width && (uint32_t)yy < c->height)
                    memset((uint8_t *)c->data + 3 * ((size_t)yy * c->width + xx), 255, 3);
    }
}

/* Renders g (the heaviest subset for view_dir when select is set; by
 * drawfn when set) at s × s. */
static sv_status draw_by(sv_renderer *r, const sv_gpu_mesh *g, sv_eval_subset_fn select,
                         sv_eval_draw_fn drawfn, void *user, const double dir[3],
                         const sv_camera *cam, const sv_render_options *ro, uint32_t s,
                         sv_image *out, sv_error *err)
{
    if (drawfn) return drawfn(user, cam, s, s, out, NULL, err);
    const uint32_t *tris = NULL;
    uint32_t count = 0;
    if (select) {
        sv_eval_subset sub[SV_EVAL_MAX_SUBSETS];
        uint32_t n = 0;
        sv_status st = select(user, dir, sub, &n, err);
        if (st != SV_OK) return st;
        uint32_t best = 0;
        for (uint32_t k = 1; k < n; k++)
            if (sub[k].weight > sub[best].weight) best = k;
        if (n) tris = sub[best].tris, count = sub[best].tri_count;
    }
    return sv_render(r, g, tris, count, cam, ro, s, s, out, NULL, err);
}

static void fmt_count(char *b, size_t n, const char *what, double v)
{
    if (v >= 1e6) snprintf(b, n, "%s %.1fM", what, v / 1e6);
    else if (v >= 1e4) snprintf(b, n, "%s %.0fk", what, v / 1e3);
    else snprintf(b, n, "%s %.0f", what, v);
}

sv_status sv_preview_chain(sv_renderer *r, const sv_gpu_mesh *original,
                           const sv_preview_level *levels, uint32_t n, const sv_camera *cam,
                           const double view_dir[3], const sv_render_options *ro, uint32_t tile,
                           const char *path, sv_error *err)
{
    if (tile < 64 || tile > 1024)
        return sv_fail(err, SV_ERR_INVALID, "preview: tile %u not in [64, 1024]", tile);
    const uint32_t t = tile, half = t / 2, h = t + half + LINES * LINE + 8;
    sv_image canvas = {0}, img = {0};
    sv_status st = sv_image_alloc(&canvas, t * (n + 1), h, 3, 8, err);
    if (st != SV_OK) return st;
    memset(canvas.data, BG, (size_t)canvas.width * canvas.height * 3);
    char line[96];
    /* column 0: the original */
    if ((st = draw_by(r, original, NULL, NULL, NULL, view_dir, cam, ro, t, &img, err)) == SV_OK) {
        blit(&canvas, &img, 0, 0);
        sv_image_free(&img);
        text(&canvas, 4, (int)(t + 4), "below: original | level");
        text(&canvas, 4, (int)(t + 4 + LINE), "at the level's switch size");
        text(&canvas, 4, (int)(t + half + 4), "original");
    }
    for (uint32_t i = 0; st == SV_OK && i < n; i++) {
        const sv_preview_level *l = &levels[i];
        uint32_t x = t * (i + 1);
        if ((st = draw_by(r, l->gpu, l->select, l->draw, l->user, view_dir, cam, ro, t, &img, err)))
            break;
        blit(&canvas, &img, x, 0);
        sv_image_free(&img);
        double px = l->pixels;
        uint32_t s = (uint32_t)fmin(fmax(round(isfinite(px) ? px : 0), 4), half - 2);
        uint32_t y = t + (half - s) / 2;
        if ((st = draw_by(r, original, NULL, NULL, NULL, view_dir, cam, ro, s, &img, err))) break;
        blit(&canvas, &img, x + half - 1 - s, y);
        sv_image_free(&img);
        if ((st = draw_by(r, l->gpu, l->select, l->draw, l->user, view_dir, cam, ro, s, &img, err)))
            break;
        blit(&canvas, &img, x + half + 1, y);
        sv_image_free(&img);
        int ty = (int)(t + half + 4);
        snprintf(line, sizeof line, "LOD%u %s", i, l->name ? l->name : "");
        text(&canvas, (int)x + 4, ty, line);
        snprintf(line, sizeof line, "switch %.0f px%s", px,
                 px > half - 2 ? " (shown smaller)" : "");
        text(&canvas, (int)x + 4, ty + LINE, line);
        fmt_count(line, sizeof line, "triangles", l->triangles);
        text(&canvas, (int)x + 4, ty + 2 * LINE, line);
        fmt_count(line, sizeof line, "texels", l->texels);
        text(&canvas, (int)x + 4, ty + 3 * LINE, line);
        if (l->iou >= 0) snprintf(line, sizeof line, "IoU %.3f @%.0f px", l->iou, l->iou_pixels);
        else snprintf(line, sizeof line, "IoU not measured");
        text(&canvas, (int)x + 4, ty + 4 * LINE, line);
    }
    if (st == SV_OK) st = sv_image_write_png(&canvas, path, err);
    sv_image_free(&img);
    sv_image_free(&canvas);
    return st;
}
