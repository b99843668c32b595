/* fuzz_sniff_precheck.c — libFuzzer target: the format sniffer, the glTF/GLB
 * pre-check and the upload reference resolver (core/io/sniff.c, core/io/gltf_precheck.c;
 * glTF 2.0 spec §4.4 file names and URIs, §4.4.3 GLB) on arbitrary bytes.
 * Every input must return a status, never crash, leak or read out of bounds. */
#include <stdlib.h>
#include <string.h>

#include "import.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    sv_format f = sv_sniff_format(data, size);
    (void)sv_format_name(f);
    /* Companions the document may name: a .bin and an image. */
    static const uint8_t bin[48] = {0};
    sv_file files[3] = {{"a.gltf", data, size}, {"a.bin", bin, sizeof bin}, {"leaf.png", bin, 8}};
    sv_limits lim = {0};
    lim.max_node_depth = 32;
    lim.max_nodes = 1000;
    sv_error e = {0};
    /* Both readings whatever the sniffer said: the pre-check must stand alone. */
    (void)sv_gltf_precheck(data, size, true, files, 3, &lim, &e);
    (void)sv_gltf_precheck(data, size, false, files, 3, NULL, &e);
    /* The bytes as a reference written inside an upload. */
    char *ref = malloc(size + 1);
    if (ref) {
        memcpy(ref, data, size);
        ref[size] = 0;
        size_t idx = 0;
        (void)sv_upload_find(files, 3, ref, &idx, &e);
        free(ref);
    }
    return 0;
}
