/* fuzz_import.c — libFuzzer target: the whole import path on arbitrary bytes
 * (a PLY header without end_header once hung assimp in it): the sniffer, the pre-checks
 * (core/io/mesh_precheck.c, core/io/gltf_precheck.c), then assimp reading the upload
 * from memory through sylva's file system (core/io/import.c), and the merge.
 * Every input must return a status, never crash, leak, read out of bounds or
 * spin (`make fuzz` runs with -timeout=10: a spin is a finding).
 *
 * Seeds: tests/fuzz/corpus/fuzz_import is a link to tests/corpus, so the whole
 * hostile corpus and the valid files of every format (tests/corpus/valid/)
 * seed it. */
#include <stdlib.h>
#include <string.h>

#include "import.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
const char *__lsan_default_suppressions(void);

/* assimp 5.2.5's FBX parser leaks every element it has read when it meets a
 * syntax error (Scope's constructor throws with raw pointers in its map), and
 * its symbols are hidden, so only the whole library can be named. sylva's
 * pre-check refuses the truncations and structural faults that reach that path
 * (test_hostile checks every prefix of a valid file under ASan with no
 * suppression, which also catches a scene sylva forgets to release), but not
 * every syntax error inside an element. A worker imports once and exits. */
const char *__lsan_default_suppressions(void)
{
    return "leak:libassimp.so\n";
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    /* Small limits: a declared count should be refused, not allocated. */
    sv_limits lim = {0};
    lim.max_triangles = 100000;
    lim.max_vertices = 300000;
    lim.max_texture_size = 1024;
    lim.max_materials = 64;
    lim.max_node_depth = 32;
    lim.max_nodes = 1000;
    sv_error e = {0};
    /* The pre-check must stand alone whatever the sniffer says. */
    for (int f = SV_FORMAT_GLB; f <= SV_FORMAT_COLLADA; f++)
        (void)sv_mesh_precheck((sv_format)f, data, size, "fuzz", &lim, &e);
    /* Companions a document may name: a .bin, an .mtl and an image. */
    static const uint8_t bin[48] = {0};
    static const char mtl[] = "newmtl m\nKd 0.5 0.5 0.5\nmap_Kd leaf.png\n";
    sv_file files[4] = {{"fuzz.bin", data, size},
                        {"a.bin", bin, sizeof bin},
                        {"a.mtl", (const uint8_t *)mtl, sizeof mtl - 1},
                        {"leaf.png", bin, 8}};
    sv_import_options opt = {0};
    opt.limits = lim;
    sv_mesh *mesh = NULL;
    sv_import_info info;
    sv_status st = sv_import(files, 4, &opt, &mesh, &info, &e);
    if (st == SV_OK) sv_mesh_destroy(mesh);
    return 0;
}
