/* registry.h — the one list of stand-in methods: a line per method.
 *
 * Each SV_METHOD(name) names a folder core/methods/name/ that defines the
 * method's schema `const sv_method sv_method_name` (method.h) and its build
 * half `const sv_method_ops sv_method_name_ops` (method_ops.h). The includer
 * defines SV_METHOD: methods.c makes the schema registry of it (what sylvad
 * links), method_ops.c the build registry (what the bake links). Adding a
 * method is its folder and one line here (docs/design.md, "Adding a method").
 * The order is the order of `GET /v1/info` and of --help.
 */
SV_METHOD(crossed_quads)
SV_METHOD(leaf_clusters)
SV_METHOD(stochastic)
SV_METHOD(slicing)
SV_METHOD(billboard_cloud)
SV_METHOD(octahedral)
