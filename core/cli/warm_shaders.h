/* warm_shaders.h — a read-only llvmpipe shader cache for sandboxed bakes
 * (sandboxed bakes run without Mesa's disk cache, so each job would
 * JIT-compile the same few shaders again; docs/benchmarks.md has the cost).
 *
 * The daemon runs `sylva-bake warm-shaders DIR` once, before any job, on a
 * scene the program builds itself (no upload is read): Mesa's single-file
 * cache (a Fossilize DB) fills with every shader a bake of it compiles. Each
 * sandboxed bake then opens that DB read-only (MESA_DISK_CACHE_READ_ONLY_FOZ_DBS)
 * and writes what it still compiles into a writable cache of its own that
 * the daemon deletes after the job, so nothing a bake does reaches a later
 * one through the cache. */
#ifndef SV_WARM_SHADERS_H
#define SV_WARM_SHADERS_H

/* `sylva-bake warm-shaders DIR`: creates DIR (it must not hold a cache of
 * an earlier run: the caller empties it), bakes the built-in scene with the
 * default spec, dynamic light and each method once with Mesa's disk cache in DIR, and
 * prints on stdout the read-only DB's path without its ".foz" suffix (the
 * form --shader-cache takes). Returns 0, or 1 with a message on stderr when
 * no DB was written (a Mesa without the single-file cache). */
int sv_warm_shaders_main(int argc, char **argv);

/* Sets Mesa's environment for one bake before any GL context exists:
 * with db (a path printed by warm-shaders) and dir (an empty writable
 * directory), the single-file cache in dir plus db read-only; otherwise, or
 * when either path cannot be used, the disk cache off. Returns 1 when the
 * read-only cache was set up, 0 when the cache is off. */
int sv_shader_cache_env(const char *db, const char *dir);

#endif
