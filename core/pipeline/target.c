/* target.c — the target search (docs/spec.md "target"; bisection): the method's ladder (its sv_method ladder hook) is
 * searched by bisection for the cheapest setting that meets the spec's
 * budget and IoU, each try a trial bake (svp_bake_all with r->trial), then
 * the chosen setting is baked with the user's own LOD settings.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "method.h"
#include "pipeline_internal.h"

/* ---- target search (docs/spec.md "target") ----
 * Step i of the method's ladder (its sv_method ladder hook) rewrites the
 * method's settings object. Returns the hook's SV_LADDER_STEP or
 * SV_LADDER_OVER, SV_LADDER_END past the last step and for a method without
 * a ladder. */
static int ladder_step(const char *method, int i, uint32_t max_triangles, cJSON *set)
{
    const sv_method *m = sv_method_find(method);
    return m && m->ladder ? m->ladder(i, max_triangles, set) : SV_LADDER_END;
}

/* The user's spec document with the method's settings replaced by `set` (a
 * copy is taken); trial = true also turns the LOD chain off (the method's own
 * level alone is judged). Returns malloc'ed JSON or NULL. */
static char *spec_with(const cJSON *root, const char *method, const cJSON *set, bool trial)
{
    cJSON *doc = root ? cJSON_Duplicate(root, true) : cJSON_CreateObject();
    if (!doc) return NULL;
    cJSON_DeleteItemFromObjectCaseSensitive(doc, method);
    cJSON_AddItemToObject(doc, method, cJSON_Duplicate(set, true));
    if (trial) {
        cJSON *lod = cJSON_GetObjectItemCaseSensitive(doc, "lod");
        if (!lod) lod = cJSON_AddObjectToObject(doc, "lod");
        cJSON_DeleteItemFromObjectCaseSensitive(lod, "chain");
        cJSON_DeleteItemFromObjectCaseSensitive(lod, "coarsest");
        cJSON_AddBoolToObject(lod, "chain", false);
        cJSON_AddStringToObject(lod, "coarsest", "none");
    }
    char *out = cJSON_PrintUnformatted(doc);
    cJSON_Delete(doc);
    return out;
}

/* Runs one bake of r (already prepared) with the given spec JSON: a trial
 * (r->trial) or the final one. r->spec is replaced by the parsed document. */
static sv_status bake_with(run *r, const char *json, sv_error *err)
{
    sv_spec next;
    sv_status st = sv_spec_parse(json, strlen(json), &next, err);
    if (st) return st;
    sv_spec_free(&r->spec);
    r->spec = next;
    return svp_bake_all(r, err);
}

/* Why a target was not met, for people (report.json target.reason, printed by
 * sylva-bake and sylva): the goal, the try that was baked (1-based, its
 * settings and cost), what it reached, and whether the search stopped at the
 * budget (`stopped`: the step after it is over the budget, tried or called
 * so by the ladder). `tries` is the report's array, `chosen` an index into
 * it. */
static void target_reason(const sv_spec *goal, const char *method, const cJSON *tries, int chosen,
                          bool stopped, char *out, size_t cap)
{
    char g[200] = "";
    size_t n = 0;
    if (goal->target_iou > 0)
        n += (size_t)snprintf(g + n, sizeof g - n, "IoU %.3g at %u px (%s)", goal->target_iou,
                              goal->target_pixels,
                              goal->target_worst ? "worst view" : "mean of views");
    if (goal->target_max_planes && n < sizeof g)
        n += (size_t)snprintf(g + n, sizeof g - n, "%sat most %u planes", n ? ", " : "",
                              goal->target_max_planes);
    if (goal->target_max_triangles && n < sizeof g)
        snprintf(g + n, sizeof g - n, "%sat most %u triangles", n ? ", " : "",
                 goal->target_max_triangles);
    const cJSON *t = cJSON_GetArrayItem(tries, chosen);
    int count = cJSON_GetArraySize(tries);
    char *set = cJSON_PrintUnformatted(cJSON_GetObjectItemCaseSensitive(t, "settings"));
    double tris = cJSON_GetNumberValue(cJSON_GetObjectItemCaseSensitive(t, "triangles"));
    double quads = cJSON_GetNumberValue(cJSON_GetObjectItemCaseSensitive(t, "quads"));
    const cJSON *iou = cJSON_GetObjectItemCaseSensitive(t, "iou");
    bool within = cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(t, "within_budget"));
    char what[300];
    snprintf(what, sizeof what, "try %d of %d, %s %s (%.0f quads, %.0f triangles)", chosen + 1,
             count, method, set ? set : "{}", quads, tris);
    free(set);
    if (!within)
        snprintf(out, cap,
                 "goal %s: even the cheapest setting, %s, is over the budget; it was baked anyway",
                 g, what);
    else
        snprintf(out, cap,
                 "goal %s: no setting reached it; the best within budget, %s, reached IoU %.3f%s",
                 g, what, cJSON_IsNumber(iou) ? floor(iou->valuedouble * 1000.0) / 1000.0 : 0.0,
                 stopped ? ", and the next step was over the budget" : "");
}

/* One step of a target search: what a try found. */
typedef struct step_try {
    bool tried, baked, within, reached;
    bool told_over; /* the ladder calls it over the triangle budget: not baked */
    bake_state *kept; /* its bake, while it may be the one chosen (s->reuse) */
    double iou; /* -1 when not measured */
    int index;  /* its place in the report's tries */
    cJSON *set; /* the method's settings, owned */
} step_try;

/* Bakes step i of the method's ladder as a trial (appending its entry to
 * tries and its seconds to secs); *fatal is set for an error that ends the
 * search (cancelled, out of memory). */
static sv_status try_step(run *r, const sv_spec *goal, const char *method, const cJSON *user_root,
                          const cJSON *us, int i, int n, step_try *o, cJSON *tries, cJSON *secs,
                          bool *fatal, sv_error *err)
{
    *fatal = false;
    o->tried = true;
    o->iou = -1;
    o->set = us ? cJSON_Duplicate(us, true) : cJSON_CreateObject();
    if (!o->set || ladder_step(method, i, goal->target_max_triangles, o->set) == SV_LADDER_END)
        return SV_ERR_INTERNAL;
    char *json = spec_with(user_root, method, o->set, true);
    if (!json) {
        *fatal = true;
        return sv_fail(err, SV_ERR_NOMEM, "out of memory");
    }
    memset(r->times, 0, sizeof r->times);
    if (r->req->search) r->req->search(r->req->user, n + 1, r->search_most);
    r->pa = 0.1 + 0.5 * (1 - ldexp(1, -n));
    r->pb = 0.1 + 0.5 * (1 - ldexp(1, -(n + 1)));
    r->trial = true;
    memset(&r->tout, 0, sizeof r->tout);
    sv_status ts = bake_with(r, json, err);
    free(json);
    r->trial = false;
    if (r->stage >= 0) r->times[r->stage] += sv_now() - r->t0; /* close the open stage */
    r->t0 = sv_now();
    double sec = 0;
    for (int k = 0; k < ST_COUNT; k++) sec += r->times[k];
    cJSON *t = cJSON_CreateObject();
    cJSON_AddNumberToObject(t, "step", i);
    cJSON_AddItemToObject(t, "settings", cJSON_Duplicate(o->set, true));
    cJSON_AddItemToArray(secs, cJSON_CreateNumber(round(sec * 1e4) / 1e4));
    o->index = cJSON_GetArraySize(tries);
    if (ts == SV_ERR_CANCELLED || ts == SV_ERR_NOMEM) {
        cJSON_Delete(t);
        *fatal = true;
        return ts;
    }
    if (ts != SV_OK) { /* a setting that cannot be baked: noted, the search goes on */
        cJSON_AddStringToObject(t, "error", err->message);
        cJSON_AddItemToArray(tries, t);
        return ts;
    }
    const trial_out *x = &r->tout;
    o->baked = true;
    o->within = (!goal->target_max_planes || x->quads <= goal->target_max_planes) &&
                (!goal->target_max_triangles || x->triangles <= goal->target_max_triangles);
    o->iou = x->iou;
    o->reached = goal->target_iou > 0 && x->iou >= goal->target_iou;
    cJSON_AddNumberToObject(t, "quads", x->quads);
    cJSON_AddNumberToObject(t, "triangles", x->triangles);
    cJSON_AddNumberToObject(t, "texels", x->texels);
    if (x->iou >= 0) cJSON_AddNumberToObject(t, "iou", x->iou);
    cJSON_AddBoolToObject(t, "within_budget", o->within);
    cJSON_AddItemToArray(tries, t);
    return SV_OK;
}

/* One search: the goal, the ladder and what each try found. */
typedef struct search {
    run *r;
    sv_spec goal; /* the user's scalars; root stays owned by r->spec */
    char method[32];
    cJSON *user_root;    /* the user's spec document, owned */
    const cJSON *us;     /* its settings of the method (may be NULL) */
    int steps, n;        /* the ladder's length; tries made */
    step_try *sr;        /* one per step */
    cJSON *tries, *secs; /* report target.tries and times.target_tries, owned */
    sv_status last;      /* the last try that could not be baked, and why */
    sv_error last_err;
    bool reuse; /* the final bake is the chosen try's (the user's chain is off): tries are kept */
} search;

static void kept_free(step_try *t)
{
    if (!t->kept) return;
    svp_bake_state_free(t->kept);
    free(t->kept);
    t->kept = NULL;
}

static void keep_candidates(search *s);

/* Tries step i unless it was tried. Returns non-zero (err set) only for an
 * error that ends the search; a step that cannot be baked is remembered. */
static sv_status probe(search *s, int i, sv_error *err)
{
    if (s->sr[i].tried) return SV_OK;
    bool fatal = false;
    sv_error e = {0};
    if (s->reuse && !(s->r->keep = sv_calloc(1, sizeof *s->r->keep)))
        return sv_fail(err, SV_ERR_NOMEM, "out of memory");
    sv_status ts = try_step(s->r, &s->goal, s->method, s->user_root, s->us, i, s->n, &s->sr[i],
                            s->tries, s->secs, &fatal, &e);
    if (s->r->keep) {
        s->sr[i].kept = s->r->keep;
        s->r->keep = NULL;
        if (!s->sr[i].baked) kept_free(&s->sr[i]);
    }
    s->n++;
    keep_candidates(s);
    if (fatal) {
        *err = e;
        return ts;
    }
    if (ts != SV_OK) s->last = ts, s->last_err = e;
    return SV_OK;
}

/* The last step the ladder does not call over the triangle budget
 * (SV_LADDER_OVER: its quads leave the trunk less than its floor), -1 when
 * it calls every step over; the last step when it calls none over (or there
 * is no triangle budget): *told says whether it called any. */
static int ladder_top(search *s, bool *told)
{
    int top = -1;
    *told = false;
    for (int i = 0; i < s->steps; i++) {
        cJSON *set = s->us ? cJSON_Duplicate(s->us, true) : cJSON_CreateObject();
        int k = set ? ladder_step(s->method, i, s->goal.target_max_triangles, set) : SV_LADDER_END;
        cJSON_Delete(set);
        s->sr[i].told_over = k == SV_LADDER_OVER;
        if (k == SV_LADDER_OVER) *told = true;
        else if (k == SV_LADDER_STEP) top = i;
    }
    return top;
}

/* *hi: the last step within the budget (-1: none). Steps the ladder calls
 * over the budget are not baked; when it called any, the last step it does
 * not is tried first (its quads and trunk are sized to fill the budget, so it
 * is within it unless the trunk cannot be simplified that far: one try
 * instead of log2 of the ladder), then bisection below it. */
static sv_status bisect_budget(search *s, int *hi, sv_error *err)
{
    bool told;
    int lo = 0, h = ladder_top(s, &told), ans = -1;
    if (told && h >= 0) {
        sv_status st = probe(s, h, err);
        if (st) return st;
        if (s->sr[h].baked && s->sr[h].within) {
            *hi = h;
            return SV_OK;
        }
        h--;
    }
    while (lo <= h) {
        int mid = (lo + h) / 2;
        sv_status st = probe(s, mid, err);
        if (st) return st;
        if (s->sr[mid].baked && s->sr[mid].within) ans = mid, lo = mid + 1;
        else h = mid - 1;
    }
    *hi = ans;
    return SV_OK;
}

/* Whether two measured steps a < b below the goal, extended in a straight
 * line to step h, still fall short of it by more than SV_TARGET_REACH_MARGIN.
 * A tree's IoU rises ever more slowly along a ladder (each step adds detail
 * the coarser ones lacked least), so the line overestimates what h gives:
 * when even the line falls short, the goal is out of reach below h. */
#define SV_TARGET_REACH_MARGIN 0.005
static bool line_falls_short(const search *s, int a, int b, int h)
{
    const step_try *x = &s->sr[a], *y = &s->sr[b];
    if (a < 0 || b <= a || h <= b || !x->baked || !y->baked || x->iou < 0 || y->iou < 0)
        return false;
    double at_h = y->iou + (y->iou - x->iou) * (double)(h - b) / (double)(b - a);
    return at_h < s->goal.target_iou - SV_TARGET_REACH_MARGIN;
}

/* *ans: the first step at or below hi that reaches the IoU (-1: none).
 * Bisection; after two tries below the goal whose trend cannot reach it by
 * the top of the range (line_falls_short), the top is tried next: if it
 * falls short too the goal is out of reach and the search ends there (the
 * steps between are not baked: the richest, the best tried, is what is
 * returned), else bisection goes on below it. An unreachable goal costs
 * three tries, not log2 of the ladder's richest steps. */
static sv_status bisect_iou(search *s, int hi, int *ans, sv_error *err)
{
    int lo = 0, h = hi, fa = -1, fb = -1; /* the last two steps below the goal */
    bool jumped = false;                   /* once: a top that reaches disproves the line */
    *ans = -1;
    while (lo <= h) {
        int mid = (lo + h) / 2;
        if (!jumped && !s->sr[h].tried && line_falls_short(s, fa, fb, h)) mid = h, jumped = true;
        sv_status st = probe(s, mid, err);
        if (st) return st;
        if (s->sr[mid].baked && s->sr[mid].reached) {
            *ans = mid, h = mid - 1;
        } else {
            lo = mid + 1;
            if (s->sr[mid].baked && s->sr[mid].iou >= 0) fa = fb, fb = mid;
        }
    }
    return SV_OK;
}

/* The best tried step when the IoU was not reached: within budget first,
 * then higher IoU, then (unmeasured) the richer step; ties to the cheaper.
 * -1 when none could be baked. */
static int best_tried(const search *s)
{
    double best_key = -2;
    int bi = -1;
    for (int i = 0; i < s->steps; i++) {
        const step_try *t = &s->sr[i];
        if (!t->baked) continue;
        double key = (t->within ? 2 : 0) + (t->iou >= 0 ? t->iou : 1e-6 * (i + 1));
        if (bi < 0 || key > best_key + 1e-12) best_key = key, bi = i;
    }
    return bi;
}

/* Frees the kept bakes of the tries that can no longer be chosen: what is
 * chosen is the best tried step (best_tried) or, with an IoU goal and no
 * budget, the cheapest tried step that reaches it (bisect_iou's answer), so
 * at most two are kept. */
static void keep_candidates(search *s)
{
    int best = best_tried(s), first = -1;
    for (int i = 0; i < s->steps && first < 0; i++)
        if (s->sr[i].baked && s->sr[i].reached) first = i;
    for (int i = 0; i < s->steps; i++)
        if (i != best && i != first) kept_free(&s->sr[i]);
}

/* report.json "target": the goal, met, the chosen try, why not met, and the
 * tries (taken from s). */
static cJSON *target_json(search *s, bool met, int chosen)
{
    const sv_spec *goal = &s->goal;
    cJSON *tj = cJSON_CreateObject();
    cJSON *g = cJSON_AddObjectToObject(tj, "goal");
    if (goal->target_iou > 0) {
        cJSON_AddNumberToObject(g, "iou", goal->target_iou);
        cJSON_AddNumberToObject(g, "pixels", goal->target_pixels);
        cJSON_AddStringToObject(g, "judged", goal->target_worst ? "worst view" : "mean of views");
    }
    if (goal->target_max_planes) cJSON_AddNumberToObject(g, "max_planes", goal->target_max_planes);
    if (goal->target_max_triangles)
        cJSON_AddNumberToObject(g, "max_triangles", goal->target_max_triangles);
    cJSON_AddBoolToObject(tj, "met", met);
    cJSON_AddNumberToObject(tj, "chosen", chosen);
    if (!met) {
        char why[700];
        const cJSON *ct = cJSON_GetArrayItem(s->tries, chosen);
        int k = (int)cJSON_GetNumberValue(cJSON_GetObjectItemCaseSensitive(ct, "step")) + 1;
        bool stopped = k > 0 && k < s->steps &&
                       (s->sr[k].told_over || (s->sr[k].baked && !s->sr[k].within));
        target_reason(goal, s->method, s->tries, chosen, stopped, why, sizeof why);
        cJSON_AddStringToObject(tj, "reason", why);
    }
    cJSON_AddStringToObject(tj, "judged_lod", "the method's finest level, baked alone");
    cJSON_AddItemToObject(tj, "tries", s->tries);
    s->tries = NULL;
    return tj;
}

/* The ladder's length, and r->search_most: at most one try per halving, per
 * bisection (budget, then IoU). */
static void count_steps(search *s)
{
    cJSON *scratch = cJSON_CreateObject();
    while (scratch && s->steps < 64 && ladder_step(s->method, s->steps, 0, scratch) != SV_LADDER_END)
        s->steps++;
    cJSON_Delete(scratch);
    int halvings = 0;
    while ((1 << halvings) <= s->steps) halvings++;
    const sv_spec *goal = &s->goal;
    int searches = (goal->target_max_planes || goal->target_max_triangles ? 1 : 0) +
                   (goal->target_iou > 0 ? 1 : 0);
    s->r->search_most = halvings * searches;
    if (s->r->search_most < 1) s->r->search_most = 1;
}

/* A target, searched by bisection. The method's ladder
 * (ladder_step) orders settings from the cheapest; a budget is crossed once
 * along it and an IoU is taken to rise along it, so both are found by
 * bisection: with a budget, the last step within it; with an IoU alone, the
 * first step that reaches it. That is about log2 of the ladder's length in
 * tries (4 of 11 cluster counts where the linear search from the cheapest
 * tried all 11 on a tree that never reaches the goal: 4.3 times one bake on
 * the sapling maple). With a budget, the tried step within it with the best
 * IoU among those that reach the goal is baked, not the cheapest that does,
 * so the IoU is not bisected for (it would only find cheaper, worse steps:
 * 6 tries → 4 for a 264-triangle billboard cloud on the bush). When the IoU
 * is not reached, or with a budget alone, the tried step within the budget
 * with the best IoU (with no evaluation: the richest) is baked. A try judges
 * the goal's size alone (pipeline.c trial_size). */
sv_status svp_target_search(run *r, sv_error *err)
{
    search s;
    memset(&s, 0, sizeof s);
    s.r = r;
    s.goal = r->spec;
    snprintf(s.method, sizeof s.method, "%s", s.goal.method);
    s.user_root = cJSON_Duplicate(r->spec.root ? r->spec.root : NULL, true);
    s.us = s.user_root ? cJSON_GetObjectItemCaseSensitive(s.user_root, s.method) : NULL;
    /* with the chain off, a try's spec (which also says lod.coarsest "none",
     * ignored without a chain) bakes what the final spec bakes */
    s.reuse = cJSON_IsFalse(cJSON_GetObjectItemCaseSensitive(
        cJSON_GetObjectItemCaseSensitive(s.user_root, "lod"), "chain"));
    s.tries = cJSON_CreateArray();
    s.secs = cJSON_CreateArray();
    const sv_spec *goal = &s.goal;
    cJSON *best_set = NULL;
    int best = -1, chosen = -1;
    bool met = false;
    sv_status st = SV_OK;
    double base[ST_COUNT];
    if (r->stage >= 0) r->times[r->stage] += sv_now() - r->t0; /* close the open stage */
    r->t0 = sv_now();
    memcpy(base, r->times, sizeof base);
    count_steps(&s);
    s.sr = sv_calloc(s.steps ? (size_t)s.steps : 1, sizeof *s.sr);
    if (!s.sr) {
        st = sv_fail(err, SV_ERR_NOMEM, "out of memory");
        goto out;
    }
    int hi = s.steps - 1;
    if ((goal->target_max_planes || goal->target_max_triangles) &&
        (st = bisect_budget(&s, &hi, err)))
        goto out;
    if (goal->target_iou > 0 && hi >= 0) {
        int ans = -1;
        if (goal->target_max_planes || goal->target_max_triangles) {
            /* within a budget, the best of the tries that reach the goal
             * (the budget is what the user pays; ties to the cheaper). The
             * IoU rises along the ladder, so no step cheaper than the last
             * one within the budget does better: the budget's bisection has
             * tried every step worth baking, none is searched for the IoU */
            for (int i = 0; i < s.steps; i++)
                if (s.sr[i].baked && s.sr[i].within && s.sr[i].reached &&
                    (ans < 0 || s.sr[i].iou > s.sr[ans].iou))
                    ans = i;
        } else if ((st = bisect_iou(&s, hi, &ans, err))) {
            goto out;
        }
        if (ans >= 0) {
            met = true;
            chosen = best = s.sr[ans].index;
            best_set = cJSON_Duplicate(s.sr[ans].set, true);
        }
    }
    /* a budget alone that every step meets still tries one */
    if (s.steps > 0 && s.n == 0 && (st = probe(&s, 0, err))) goto out;
    if (!met) {
        int bi = best_tried(&s);
        if (bi >= 0) {
            best = s.sr[bi].index;
            best_set = cJSON_Duplicate(s.sr[bi].set, true);
        }
    }
    if (best < 0) { /* no setting could be baked */
        *err = s.last_err;
        st = s.last ? s.last
                    : sv_fail(err, SV_ERR_UNBAKEABLE, "target: method %s has no knobs to search",
                              s.method);
        goto out;
    }
    if (chosen < 0) {
        chosen = best;
        /* a budget alone is met by its best setting within budget */
        const cJSON *bt = cJSON_GetArrayItem(s.tries, best);
        met = goal->target_iou == 0 &&
              cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(bt, "within_budget"));
    }
    r->target_json = target_json(&s, met, chosen);
    r->target_times = s.secs;
    s.secs = NULL;
    char *json = spec_with(s.user_root, s.method, best_set, false);
    if (!json) {
        st = sv_fail(err, SV_ERR_NOMEM, "out of memory");
        goto out;
    }
    memcpy(r->times, base, sizeof base);
    for (int i = 0; i < s.steps; i++)
        if (s.sr[i].baked && s.sr[i].index == best && s.sr[i].kept) {
            r->reuse = s.sr[i].kept; /* the final bake measures and writes it */
            s.sr[i].kept = NULL;
        }
    if (r->req->search) r->req->search(r->req->user, 0, r->search_most);
    r->pa = 0.6;
    r->pb = 1.0;
    st = bake_with(r, json, err);
    free(json);
out:
    for (int i = 0; s.sr && i < s.steps; i++) {
        cJSON_Delete(s.sr[i].set);
        kept_free(&s.sr[i]);
    }
    free(s.sr);
    cJSON_Delete(s.tries);
    cJSON_Delete(s.secs);
    cJSON_Delete(best_set);
    cJSON_Delete(s.user_root);
    return st;
}
