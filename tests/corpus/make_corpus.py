#!/usr/bin/env python3
"""make_corpus.py — writes sylva's hostile-input corpus (issue 12, "Bad input").

Usage: python3 tests/corpus/make_corpus.py [DIR]   (default: the directory of
this script); python3 tests/corpus/make_corpus.py --fuzz-seeds tests/fuzz/corpus
writes the libFuzzer seed corpora. Deterministic: the same script always writes the same bytes, so
the committed files can be checked with `git diff` after a rerun; tests/unit/test_hostile.c
reruns it into a temporary directory and compares every file byte for byte.

Every file is a single mesh upload that sylva must refuse: `sylva-bake info`
and `sylva-bake bake` exit 1 with one line on stderr (never a signal), and
sylvad answers 4xx at upload or fails the job with a clear error code. The
expected outcome is in the file's name prefix and in MANIFEST.tsv (name, what
it attacks).

valid/ holds one small valid file per accepted format and encoding (VALID):
test_hostile.c imports each, then every prefix of it (cut at every byte)
under a CPU limit: each prefix must be refused or imported, never hang.

canary.mtl is the canary: several files reference it by absolute path
(/proc/self/cwd/canary.mtl: the tests run the baker with the canary in its
working directory), by `..`, by `file:` and percent-encoded forms. Its marker
(CANARY_MARKER below) must never appear in any output, log or artifact.
"""
import json
import os
import struct
import sys

CANARY_MARKER = "SYLVA_CANARY_8c1f2e4d"
CANARY = ("# %s: if these bytes appear in any output, a file outside the upload was read\n"
          "newmtl %s\nKd 0.11 0.22 0.33\nmap_Kd %s.png\n") % (CANARY_MARKER, CANARY_MARKER,
                                                              CANARY_MARKER)
CANARY_ABS = "/proc/self/cwd/canary.mtl"

ASSET = {"version": "2.0", "generator": "sylva hostile corpus"}


def pad4(b, fill=b"\0"):
    return b + fill * ((4 - len(b) % 4) % 4)


def glb(doc, bin_bytes=None, version=2, total=None, json_len=None):
    """A GLB container; total/json_len override the header fields (to lie)."""
    j = pad4(json.dumps(doc, separators=(",", ":")).encode(), b" ")
    body = struct.pack("<II", len(j) if json_len is None else json_len, 0x4E4F534A) + j
    if bin_bytes is not None:
        bb = pad4(bin_bytes)
        body += struct.pack("<II", len(bb), 0x004E4942) + bb
    length = 12 + len(body) if total is None else total
    return struct.pack("<III", 0x46546C67, version, length) + body


def tri_doc(nverts, nidx, buffer=None, pos_bytes=None, idx_count=None, extra=None):
    """glTF with one triangle-list primitive: positions then uint32 indices in
    buffer 0. `buffer` replaces the buffer object (uri tricks)."""
    pos_len = nverts * 12 if pos_bytes is None else pos_bytes
    idx_len = nidx * 4
    doc = {
        "asset": ASSET,
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "buffers": [buffer or {"byteLength": pos_len + idx_len}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": pos_len},
            {"buffer": 0, "byteOffset": pos_len, "byteLength": idx_len},
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": nverts, "type": "VEC3",
             "min": [0, 0, 0], "max": [1, 1, 1]},
            {"bufferView": 1, "componentType": 5125,
             "count": nidx if idx_count is None else idx_count, "type": "SCALAR"},
        ],
    }
    if extra:
        extra(doc)
    return doc


def tri_bin(positions, indices):
    return struct.pack("<%df" % len(positions), *positions) + struct.pack(
        "<%dI" % len(indices), *indices)


GOOD_POS = [0, 0, 0, 1, 0, 0, 0, 1, 0]
GOOD_IDX = [0, 1, 2]


def tri_glb(positions=GOOD_POS, indices=GOOD_IDX, **kw):
    b = tri_bin(positions, indices)
    return glb(tri_doc(len(positions) // 3, len(indices), **kw), b)


def gltf_text(doc):
    return json.dumps(doc, separators=(",", ":")).encode()


def ref_gltf(uri, what="buffer"):
    """A glTF whose buffer (or image) uri points outside the upload."""
    if what == "buffer":
        return gltf_text(tri_doc(3, 3, buffer={"uri": uri, "byteLength": len(CANARY)}))
    import base64
    b = tri_bin(GOOD_POS, GOOD_IDX)
    uri_data = "data:application/octet-stream;base64," + base64.b64encode(b).decode()

    def add_image(doc):
        doc["images"] = [{"uri": uri}]
        doc["textures"] = [{"source": 0}]
        doc["materials"] = [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]
        doc["meshes"][0]["primitives"][0]["material"] = 0
    return gltf_text(tri_doc(3, 3, buffer={"uri": uri_data, "byteLength": len(b)},
                             extra=add_image))


def deep_nodes(depth):
    nodes = [{"children": [i + 1]} for i in range(depth - 1)] + [{"mesh": 0}]
    def f(doc):
        doc["nodes"] = nodes
    return f


def cyclic_nodes(doc):
    doc["nodes"] = [{"children": [1]}, {"children": [2]}, {"children": [0], "mesh": 0}]


def self_child(doc):
    doc["nodes"] = [{"children": [0], "mesh": 0}]


def shared_child(doc):
    doc["nodes"] = [{"children": [2]}, {"children": [2]}, {"mesh": 0}]
    doc["scenes"] = [{"nodes": [0, 1]}]


def negative_indices(doc):
    doc["meshes"][0]["primitives"][0]["indices"] = -1
    doc["nodes"] = [{"mesh": 0, "children": [-1]}]


def data_buffer_glTF(extra=None, positions=GOOD_POS, indices=GOOD_IDX):
    import base64
    b = tri_bin(positions, indices)
    uri = "data:application/octet-stream;base64," + base64.b64encode(b).decode()
    return gltf_text(tri_doc(len(positions) // 3, len(indices),
                             buffer={"uri": uri, "byteLength": len(b)}, extra=extra))


NAN = float("nan")
INF = float("inf")


def obj(text):
    return text.encode()


TRI_V = "v 0 0 0\nv 1 0 0\nv 0 1 0\n"

# --- small valid files, one per accepted format (and encoding): the bases of
# the truncation sweep in tests/unit/test_hostile.c (every prefix must be
# refused or imported within a CPU limit) and seeds of fuzz_import.
def fbx_tree():
    """One triangle as an FBX node tree: (name, [(type, value)], children)."""
    L = lambda v: ("L", v)
    return [
        ("FBXHeaderExtension", [], [("FBXHeaderVersion", [("I", 1003)], []),
                                    ("FBXVersion", [("I", 7400)], [])]),
        ("Objects", [], [
            ("Geometry", [L(1000001), ("S", "Geometry::tri"), ("S", "Mesh")], [
                ("Vertices", [("d", [0, 0, 0, 1, 0, 0, 0, 1, 0])], []),
                ("PolygonVertexIndex", [("i", [0, 1, -3])], []),
            ]),
            ("Model", [L(1000002), ("S", "Model::tri"), ("S", "Mesh")], [
                ("Version", [("I", 232)], [])]),
        ]),
        ("Connections", [], [
            ("C", [("S", "OO"), L(1000002), L(0)], []),
            ("C", [("S", "OO"), L(1000001), L(1000002)], []),
        ]),
    ]


def fbx_ascii(tree):
    out = ["; FBX 7.4.0 project file\n"]

    def val(p):
        return '"%s"' % p[1] if p[0] == "S" else str(p[1])

    def node(n, ind):
        name, props, kids = n
        pad = "\t" * ind
        if len(props) == 1 and props[0][0] in "di":
            arr = props[0][1]
            out.append("%s%s: *%d {\n%s\ta: %s\n%s}\n" % (
                pad, name, len(arr), pad, ",".join(str(x) for x in arr), pad))
            return
        line = "%s%s: %s" % (pad, name, ", ".join(val(p) for p in props))
        if kids:
            out.append(line + " {\n")
            for k in kids:
                node(k, ind + 1)
            out.append(pad + "}\n")
        else:
            out.append(line + "\n")
    for n in tree:
        node(n, 0)
    return "".join(out).encode()


def fbx_binary(tree, version=7400):
    """Binary FBX (32-bit record headers, version < 7500): each record is
    endOffset, numProperties, propertyListLen, nameLen, name, properties,
    nested records closed by a 13-byte null record; the top-level list too."""
    def prop(p):
        t, v = p
        if t == "I":
            return b"I" + struct.pack("<i", v)
        if t == "L":
            return b"L" + struct.pack("<q", v)
        if t == "S":
            b = v.encode()
            return b"S" + struct.pack("<I", len(b)) + b
        fmt = {"d": "d", "i": "i"}[t]
        b = struct.pack("<%d%s" % (len(v), fmt), *v)
        return t.encode() + struct.pack("<III", len(v), 0, len(b)) + b

    def node(n, off):
        name, props, kids = n
        pb = b"".join(prop(p) for p in props)
        cur = off + 13 + len(name) + len(pb)
        kb = b""
        if kids:
            for k in kids:
                b = node(k, cur)
                kb += b
                cur += len(b)
            kb += b"\0" * 13
            cur += 13
        return struct.pack("<IIIB", cur, len(props), len(pb), len(name)) + name.encode() + pb + kb
    out = b"Kaydara FBX Binary  \x00\x1a\x00" + struct.pack("<I", version)
    for n in tree:
        out += node(n, len(out))
    return out + b"\0" * 13


PLY_HEAD = ("ply\nformat %s 1.0\ncomment sylva\nelement vertex 3\nproperty float x\n"
            "property float y\nproperty float z\nelement face 1\n"
            "property list uchar int vertex_indices\nend_header\n")


def ply_binary(big=False):
    e = ">" if big else "<"
    return (PLY_HEAD % ("binary_big_endian" if big else "binary_little_endian")).encode() + \
        struct.pack(e + "9f", *GOOD_POS) + struct.pack(e + "B3i", 3, 0, 1, 2)


DAE_TRI = (
    '<?xml version="1.0" encoding="utf-8"?>\n'
    '<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">\n'
    '<asset><unit meter="1"/><up_axis>Y_UP</up_axis></asset>\n'
    '<library_geometries><geometry id="g"><mesh>\n'
    '<source id="p"><float_array id="pa" count="9">0 0 0 1 0 0 0 1 0</float_array>\n'
    '<technique_common><accessor source="#pa" count="3" stride="3"><param name="X" type="float"/>'
    '<param name="Y" type="float"/><param name="Z" type="float"/></accessor></technique_common>'
    '</source>\n<vertices id="v"><input semantic="POSITION" source="#p"/></vertices>\n'
    '<triangles count="1"><input semantic="VERTEX" source="#v" offset="0"/><p>0 1 2</p>'
    '</triangles>\n</mesh></geometry></library_geometries>\n'
    '<library_visual_scenes><visual_scene id="s"><node id="n"><instance_geometry url="#g"/>'
    '</node></visual_scene></library_visual_scenes>\n'
    '<scene><instance_visual_scene url="#s"/></scene>\n</COLLADA>\n').encode()

VALID = [
    ("tri.glb", tri_glb()),
    ("tri.gltf", data_buffer_glTF()),
    ("tri.obj", obj("# one triangle\no tri\n" + TRI_V + "vn 0 0 1\nvt 0 0\nf 1 2 3\n")),
    ("tri_ascii.ply", obj(PLY_HEAD % "ascii" + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")),
    ("tri_binary_le.ply", ply_binary()),
    ("tri_binary_be.ply", ply_binary(big=True)),
    ("tri_ascii.fbx", fbx_ascii(fbx_tree())),
    ("tri_binary.fbx", fbx_binary(fbx_tree())),
    ("tri.dae", DAE_TRI),
]

FBX_BIN = fbx_binary(fbx_tree())


def fbx_patch(data, off, value):
    return data[:off] + struct.pack("<I", value) + data[off + 4:]


def fbx_deep(depth):
    """Records nested `depth` deep (each holds the next), then null records."""
    n = ("N", [], [])
    for _ in range(depth - 1):
        n = ("N", [], [n])
    return fbx_binary([n])


def fbx_array_bomb():
    """A 'd' array whose zlib stream is 16 bytes and claims 2^28 doubles."""
    head = b"Kaydara FBX Binary  \x00\x1a\x00" + struct.pack("<I", 7400)
    props = b"d" + struct.pack("<III", 2 ** 28, 1, 16) + b"\x78\x9c" + b"\0" * 14
    name = b"Vertices"
    rec_len = 13 + len(name) + len(props)
    rec = struct.pack("<IIIB", len(head) + rec_len, 1, len(props), len(name)) + name + props
    return head + rec + b"\0" * 13


CORPUS = [
    # --- truncated and lying GLBs
    ("glb_truncated_header.glb", b"glTF\x02\x00\x00", "GLB cut inside its 12-byte header"),
    ("glb_truncated_chunk.glb", tri_glb()[:40], "GLB cut inside its JSON chunk"),
    ("glb_total_length_lies.glb", glb(tri_doc(3, 3), tri_bin(GOOD_POS, GOOD_IDX),
                                      total=0xFFFFFFF0), "header length 4 GiB"),
    ("glb_json_length_lies.glb", glb(tri_doc(3, 3), tri_bin(GOOD_POS, GOOD_IDX),
                                     json_len=0x7FFFFFF0), "JSON chunk length past the end"),
    ("glb_bin_shorter_than_buffer.glb", glb(tri_doc(3, 3, buffer={"byteLength": 100000}),
                                            tri_bin(GOOD_POS, GOOD_IDX)),
     "buffer byteLength 100000, BIN chunk 48 bytes"),
    ("glb_version_1.glb", glb(tri_doc(3, 3), tri_bin(GOOD_POS, GOOD_IDX), version=1),
     "GLB version 1"),
    ("glb_accessor_count_2_31.glb", tri_glb(idx_count=2 ** 31), "accessor count 2^31"),
    ("glb_view_offset_2_53.glb", tri_glb(extra=lambda d: d["bufferViews"][1].update(
        byteOffset=2 ** 53)), "bufferView byteOffset 2^53"),
    ("glb_view_past_buffer.glb", tri_glb(extra=lambda d: d["bufferViews"][1].update(
        byteLength=4096)), "bufferView past the end of its buffer"),
    ("glb_only_magic.glb", b"glTF", "only the magic"),
    # --- non-finite and out-of-range geometry
    ("glb_nan_positions.glb", tri_glb(positions=[NAN, 0, 0, 1, NAN, 0, 0, 1, NAN]),
     "NaN coordinates"),
    ("glb_inf_positions.glb", tri_glb(positions=[INF, 0, 0, 1, -INF, 0, 0, 1, 0]),
     "Inf coordinates"),
    ("glb_index_out_of_range.glb", tri_glb(indices=[0, 1, 7]), "index 7 of 3 vertices"),
    ("glb_index_uint32_max.glb", tri_glb(indices=[0, 1, 0xFFFFFFFF]), "index 2^32-1"),
    ("glb_all_degenerate.glb", tri_glb(positions=[0, 0, 0, 1, 1, 1, 2, 2, 2, 3, 3, 3],
                                       indices=[0, 1, 2, 1, 2, 3, 0, 0, 0]),
     "every triangle has zero area"),
    ("gltf_negative_indices.gltf", data_buffer_glTF(extra=negative_indices),
     "negative accessor and node indices"),
    ("gltf_huge_count.gltf", data_buffer_glTF(
        extra=lambda d: d["accessors"][0].update(count=1e308)), "count 1e308"),
    # --- node graphs
    ("gltf_deep_nodes.gltf", data_buffer_glTF(extra=deep_nodes(5000)),
     "node chain 5000 deep (assimp recurses per level)"),
    ("gltf_cyclic_nodes.gltf", data_buffer_glTF(extra=cyclic_nodes), "node cycle 0->1->2->0"),
    ("gltf_self_child.gltf", data_buffer_glTF(extra=self_child), "node is its own child"),
    ("gltf_shared_child.gltf", data_buffer_glTF(extra=shared_child), "node with two parents"),
    # --- deeply nested JSON
    ("gltf_nested_json.gltf", b'{"asset":{"version":"2.0"},"extras":' + b"[" * 20000 +
     b"]" * 20000 + b"}", "arrays nested 20000 deep"),
    ("glb_nested_json.glb", (lambda j: struct.pack("<III", 0x46546C67, 2, 20 + len(j)) +
                             struct.pack("<II", len(j), 0x4E4F534A) + j)(
        pad4(b'{"asset":{"version":"2.0"},"x":' + b'{"a":' * 10000 + b"1" + b"}" * 10000 + b"}",
             b" ")), "objects nested 10000 deep inside a GLB"),
    # --- references outside the upload (the canary)
    ("gltf_buffer_abs_path.gltf", ref_gltf(CANARY_ABS), "buffer uri: absolute path"),
    ("gltf_buffer_dotdot.gltf", ref_gltf("../canary.mtl"), "buffer uri: .."),
    ("gltf_buffer_file_uri.gltf", ref_gltf("file://" + CANARY_ABS), "buffer uri: file://"),
    ("gltf_buffer_pct_dotdot.gltf", ref_gltf("%2e%2e/canary.mtl"), "buffer uri: %2e%2e/"),
    ("gltf_buffer_backslash.gltf", ref_gltf("..\\canary.mtl"), "buffer uri: ..\\"),
    ("gltf_buffer_not_uploaded.gltf", ref_gltf("canary.mtl"),
     "buffer uri: a safe name that was not uploaded (must not be read from disk)"),
    ("gltf_image_abs_path.gltf", ref_gltf("/etc/passwd", what="image"), "image uri: /etc/passwd"),
    ("gltf_image_file_uri.gltf", ref_gltf("file:canary.mtl", what="image"), "image uri: file:"),
    ("obj_mtllib_abs_path.obj", obj("mtllib %s\n%sf 1 2 3\n" % (CANARY_ABS, TRI_V)),
     "mtllib absolute path"),
    ("obj_mtllib_dotdot.obj", obj("mtllib ../canary.mtl\n%sf 1 2 3\n" % TRI_V), "mtllib .."),
    ("obj_mtllib_file_uri.obj", obj("mtllib file:canary.mtl\n%sf 1 2 3\n" % TRI_V),
     "mtllib file:"),
    # A missing .mtl is refused ("missing") unless the spec says
    # import.missing_files "warn"; this one's faces are also all zero-area, so
    # the bake is refused either way, and the canary check proves the importer
    # did not read canary.mtl from the disk meanwhile.
    ("obj_mtllib_not_uploaded.obj", obj("mtllib canary.mtl\nusemtl m\nv 0 0 0\nv 1 1 1\n"
                                        "v 2 2 2\nf 1 2 3\n"),
     "mtllib of a file that was not uploaded (plus zero-area faces)"),
    ("dae_external_entity.dae", obj(
        '<?xml version="1.0"?>\n<!DOCTYPE c [<!ENTITY x SYSTEM "file://%s">]>\n'
        '<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">'
        '<asset><unit meter="1"/><up_axis>Y_UP</up_axis></asset>'
        '<library_images><image id="i"><init_from>%s</init_from></image></library_images>'
        '<library_geometries><geometry id="g"><mesh><source id="p"><float_array id="pa" count="3">&x;'
        '</float_array></source></mesh></geometry></library_geometries></COLLADA>\n'
        % (CANARY_ABS, CANARY_ABS)), "XML external entity and image path to the canary"),
    # --- OBJ geometry
    ("obj_index_out_of_range.obj", obj(TRI_V + "f 1 2 99\n"), "face index 99 of 3"),
    ("obj_negative_index_out_of_range.obj", obj(TRI_V + "f -1 -2 -9\n"),
     "relative index before the first vertex"),
    ("obj_nan.obj", obj("v nan nan nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"), "NaN coordinates"),
    ("obj_inf.obj", obj("v inf 0 0\nv 1 -inf 0\nv 0 1 1e999\nf 1 2 3\n"), "Inf coordinates"),
    ("obj_all_degenerate.obj", obj("v 0 0 0\nv 1 1 1\nv 2 2 2\nf 1 2 3\nf 1 1 1\nf 2 2 3\n"),
     "every triangle has zero area"),
    ("obj_no_faces.obj", obj(TRI_V), "vertices and no faces"),
    ("obj_index_2_31.obj", obj(TRI_V + "f 1 2 2147483648\n"), "face index 2^31"),
    # --- PLY, FBX
    ("ply_vertex_count_2_31.ply", obj("ply\nformat ascii 1.0\nelement vertex 2147483648\n"
                                      "property float x\nproperty float y\nproperty float z\n"
                                      "element face 1\nproperty list uchar int vertex_indices\n"
                                      "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"),
     "declares 2^31 vertices, holds 3"),
    ("ply_binary_truncated.ply", obj("ply\nformat binary_little_endian 1.0\nelement vertex 3\n"
                                     "property float x\nproperty float y\nproperty float z\n"
                                     "element face 1\nproperty list uchar int vertex_indices\n"
                                     "end_header\n") + b"\0\0\0\0\0\0",
     "binary body cut short"),
    ("fbx_truncated.fbx", b"Kaydara FBX Binary  \x00\x1a\x00\xe8\x1c\x00\x00" + b"\xff" * 13,
     "binary FBX cut after its header"),
    # --- issue 25: incomplete headers, counts the body cannot hold, broken
    # structure in every format passed to assimp (each once spun or could spin)
    ("ply_header_no_end.ply", b"ply\nformat ascii 1.0\nelement vertex 1\n",
     "PLY header without end_header (assimp 5.2.5 spins forever)"),
    ("ply_header_no_end.glb", b"ply\nformat ascii 1.0\nelement vertex 1\n",
     "the same bytes named .glb (sniffed as PLY)"),
    ("ply_header_unbounded.ply", obj("ply\nformat ascii 1.0\n" +
                                     ("comment " + "x" * 99 + "\n") * 700),
     "70 KB of header lines and no end_header"),
    ("ply_ascii_count_past_body.ply", obj((PLY_HEAD % "ascii").replace(
        "element vertex 3", "element vertex 1000") + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"),
     "declares 1000 vertices, body holds 4 lines"),
    ("ply_ascii_short_list.ply", obj(PLY_HEAD % "ascii" + "0 0 0\n1 0 0\n0 1 0\n3 0 1"),
     "face list of 3 ends after 2 indices"),
    ("ply_binary_list_count_lies.ply", ply_binary()[:-13] + struct.pack("<B3i", 255, 0, 1, 2),
     "binary face list claims 255 indices, holds 3"),
    # found by fuzz_import: assimp's TriangulateProcess aborts on an empty polygon
    ("ply_binary_empty_face.ply", ply_binary()[:-13] + struct.pack("<B", 0),
     "binary face with no vertex indices (assimp asserts and aborts)"),
    ("ply_ascii_empty_face.ply", obj(PLY_HEAD % "ascii" + "0 0 0\n1 0 0\n0 1 0\n0\n"),
     "ascii face with no vertex indices (assimp asserts and aborts)"),
    ("ply_bad_property_type.ply", obj((PLY_HEAD % "ascii").replace("property float z",
                                                                    "property quad z") +
                                      "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"),
     "unknown property type"),
    ("obj_long_line.obj", obj(TRI_V + "# " + "x" * 70000 + "\nf 1 2 3\n"),
     "a 70 KB line"),
    ("obj_continued_face.obj",
     obj("".join("v %d %d 0\n" % (k % 7, k // 7) for k in range(300)) + "f" +
         "".join(" %d \\\n" % (k + 1) for k in range(299)) + " 300\n"),
     "a 300-vertex face continued over 300 lines with '\\' (assimp joins them)"),
    ("obj_continuation_cr.obj", obj(TRI_V + "f 1 2 \\\r3\n"),
     "a '\\' continuation before a lone CR (assimp skips to the next newline)"),
    ("obj_nul_after_64k.obj", obj(TRI_V + ("# " + "x" * 98 + "\n") * 700) + b"\0f 1 2 3\n",
     "NUL byte after the sniffer's 64 KiB"),
    ("fbx_binary_offset_past_end.fbx", fbx_patch(FBX_BIN, 27, 0xFFFFFF00),
     "binary FBX record end offset 4 GiB"),
    ("fbx_binary_deep.fbx", fbx_deep(200), "binary FBX records nested 200 deep"),
    ("fbx_binary_array_bomb.fbx", fbx_array_bomb(),
     "zlib array of 16 bytes claims 2^28 doubles"),
    ("fbx_binary_cut.fbx", FBX_BIN[:len(FBX_BIN) // 2], "binary FBX cut in half"),
    ("fbx_ascii_unclosed.fbx", fbx_ascii(fbx_tree())[:200], "ascii FBX cut inside a brace"),
    ("dae_truncated.dae", DAE_TRI[:len(DAE_TRI) // 2], "COLLADA cut in half"),
    # found by fuzz_import: assimp 5.2.5 dereferences null on an array's count
    ("dae_array_no_count.dae", DAE_TRI.replace(b' count="9"', b''),
     "float_array without count (assimp segfaults)"),
    ("dae_array_count_zero.dae", DAE_TRI.replace(b' count="9"', b' count="0"'),
     "float_array with count 0 (assimp segfaults)"),
    # --- formats disguised as GLB, empty and one-byte files
    ("disguised_png.glb", b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR\x00\x00\x00\x01\x00\x00\x00\x01"
     b"\x08\x06\x00\x00\x00\x1f\x15\xc4\x89", "a PNG named .glb"),
    ("disguised_zip.glb", b"PK\x03\x04\x14\x00\x00\x00\x00\x00" + b"\0" * 20, "a ZIP named .glb"),
    ("disguised_elf.glb", b"\x7fELF\x02\x01\x01\x00" + b"\0" * 56, "an ELF named .glb"),
    ("disguised_html.glb", b"<!doctype html><html><body>glTF</body></html>\n",
     "HTML named .glb"),
    ("disguised_json.glb", b'{"hello": "world", "version": "2.0"}', "JSON that is not glTF"),
    ("disguised_stl.glb", b"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n"
     b"vertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid x\n", "ASCII STL named .glb"),
    ("empty.glb", b"", "zero bytes"),
    ("one_byte.glb", b"g", "one byte"),
    ("one_byte_nul.obj", b"\0", "one NUL byte"),
]


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.dirname(os.path.abspath(__file__))
    os.makedirs(out, exist_ok=True)
    names = set()
    with open(os.path.join(out, "MANIFEST.tsv"), "w") as man:
        man.write("# name\twhat it attacks (every file must be refused; see make_corpus.py)\n")
        for name, data, what in CORPUS:
            assert name not in names, name
            names.add(name)
            with open(os.path.join(out, name), "wb") as f:
                f.write(data)
            man.write("%s\t%s\n" % (name, what))
    vdir = os.path.join(out, "valid")
    os.makedirs(vdir, exist_ok=True)
    for name, data in VALID:
        with open(os.path.join(vdir, name), "wb") as f:
            f.write(data)
    with open(os.path.join(out, "canary.mtl"), "w") as f:
        f.write(CANARY)
    with open(os.path.join(out, "CANARY_MARKER"), "w") as f:
        f.write(CANARY_MARKER + "\n")
    print("%d hostile files and %d valid ones in %s" % (len(CORPUS), len(VALID), out))


if __name__ == "__main__" and (len(sys.argv) < 2 or sys.argv[1] != "--fuzz-seeds"):
    main()


def fuzz_seeds(root):
    """Seed corpora of the libFuzzer targets (tests/fuzz/corpus/<target>/)."""
    import base64
    seeds = {
        "fuzz_sniff_precheck": {
            "tri.glb": tri_glb(),
            "tri_data.gltf": data_buffer_glTF(),
            "tri_bin.gltf": gltf_text(tri_doc(3, 3, buffer={"uri": "a.bin", "byteLength": 48})),
            "image.gltf": ref_gltf("leaf.png", what="image"),
            "cycle.gltf": data_buffer_glTF(extra=cyclic_nodes),
            "deep.gltf": data_buffer_glTF(extra=deep_nodes(40)),
            "tri.obj": obj("mtllib a.mtl\n" + TRI_V + "f 1 2 3\n"),
            "tri.ply": obj("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                           "property float y\nproperty float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n"),
            "dae.dae": b'<?xml version="1.0"?><COLLADA version="1.4.1"></COLLADA>',
            "fbx.fbx": b"; FBX 7.4.0 project file\n",
            "ref_pct.txt": b"my%20leaf.png",
            "ref_dotdot.txt": b"%2e%2e/a.bin",
        },
        "fuzz_spec": {
            "empty.json": b"{}",
            "full.json": json.dumps({
                "method": "billboard_cloud", "billboard_cloud": {},
                "scene": {"viewer": "ground", "lighting": "dynamic", "shadows": True},
                "import": {"unit_scale": 0.01, "up": "Z"},
                "classify": {"foliage": ["leaf*"], "trunk": ["bark*"]},
                "bake": {"max_atlas": 1024, "supersample": 4, "alpha_threshold": 0.5},
                "evaluate": {"views": 8, "sizes": [128, 64]},
                "lod": {"tolerance": 0.2, "chain": False, "coarsest": ""}, "seed": 7}).encode(),
            "cq.json": b'{"method":"crossed_quads","crossed_quads":{"planes":3,"horizontal":true}}',
            "lc.json": b'{"method":"leaf_clusters","evaluate":{"views":4}}',
            "sl.json": b'{"method":"slicing"}',
            "bad.json": b'{"scene":{"viewer":"underwater"}}',
        },
        "fuzz_multipart": {
            "two_parts.txt": (b"\x05multipart/form-data; boundary=xyzBOUNDARY\n"
                              b"--xyzBOUNDARY\r\nContent-Disposition: form-data; name=\"spec\"\r\n"
                              b"\r\n{}\r\n--xyzBOUNDARY\r\nContent-Disposition: form-data; "
                              b"name=\"mesh\"; filename=\"a.obj\"\r\nContent-Type: text/plain\r\n"
                              b"\r\nv 0 0 0\r\n--xyzBOUNDARY--\r\n"),
            "quoted.txt": (b"\x00multipart/form-data; boundary=\"xyzBOUNDARY\"\n--xyzBOUNDARY\r\n"
                           b"Content-Disposition: form-data; name=file; filename=\"b.bin\"\r\n\r\n"
                           b"\r\n--xyzBOUN\r\n--xyzBOUNDARY--"),
        },
        "fuzz_validate": {
            "tri.bin": bytes([3, 1, 1, 1]) + struct.pack("<9I", 0, 0, 0, 1, 0, 0, 0, 1, 0) +
            struct.pack("<3I", 0, 1, 2),
            "dup.bin": bytes([4, 3, 1, 1]) + struct.pack("<12I", *range(12)) +
            struct.pack("<9I", 0, 1, 2, 1, 2, 0, 0, 0, 3),
            "nan.bin": bytes([3, 1, 1, 0]) + struct.pack("<9f", NAN, 0, 0, 1, 0, 0, 0, 1, 0) +
            struct.pack("<3I", 0, 1, 2),
            "bad_index.bin": bytes([3, 1, 1, 5]) + struct.pack("<9I", *range(9)) +
            struct.pack("<3I", 0, 1, 9),
        },
    }
    # fuzz_import is seeded with the whole hostile corpus and valid/ (a link,
    # so the seeds never drift from the corpus; libFuzzer reads it recursively).
    link = os.path.join(root, "fuzz_import")
    if not os.path.lexists(link):
        os.makedirs(root, exist_ok=True)
        os.symlink(os.path.relpath(os.path.dirname(os.path.abspath(__file__)), root), link)
    for target, files in seeds.items():
        d = os.path.join(root, target)
        os.makedirs(d, exist_ok=True)
        for name, data in files.items():
            with open(os.path.join(d, name), "wb") as f:
                f.write(data)
    print("fuzz seeds in %s" % root)


if __name__ == "__main__" and len(sys.argv) > 2 and sys.argv[1] == "--fuzz-seeds":
    fuzz_seeds(sys.argv[2])
