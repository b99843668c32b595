/* vec3.h — the small 3-vector helpers every geometry file needs, in one place
 * (one definition of each, one rule for a zero vector). */
#ifndef SV_VEC3_H
#define SV_VEC3_H

#include <math.h>
#include <stdbool.h>

/* a · b */
static inline double sv_dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* o = a × b; o may be a or b. */
static inline void sv_cross3(const double a[3], const double b[3], double o[3])
{
    double r0 = a[1] * b[2] - a[2] * b[1], r1 = a[2] * b[0] - a[0] * b[2],
           r2 = a[0] * b[1] - a[1] * b[0];
    o[0] = r0, o[1] = r1, o[2] = r2;
}

/* |a| */
static inline double sv_norm3(const double a[3])
{
    return sqrt(sv_dot3(a, a));
}

/* Scales v to unit length. False, v unchanged, when its length is 0 or not
 * finite (a degenerate normal stays the caller's to handle). */
static inline bool sv_normalize3(double v[3])
{
    double l = sv_norm3(v);
    if (!(l > 0) || !isfinite(l)) return false;
    v[0] /= l;
    v[1] /= l;
    v[2] /= l;
    return true;
}

#endif
