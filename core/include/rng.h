/* rng.h — the one seeded random number generator of core: splitmix64
 * (G. Steele, D. Lea, C. Flood, "Fast splittable pseudorandom number
 * generators", OOPSLA 2014). Every random choice of a bake derives from the
 * spec's seed through it, so the same spec gives the same bytes. */
#ifndef SV_RNG_H
#define SV_RNG_H

#include <stdint.h>

/* Advances the state *s and returns the next 64 random bits. */
static inline uint64_t sv_splitmix64(uint64_t *s)
{
    uint64_t z = (*s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

#endif
