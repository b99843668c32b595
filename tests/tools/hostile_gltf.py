#!/usr/bin/env python3
"""hostile_gltf.py — writes small glTF/GLB files whose accessors or JSON the
pre-check must refuse (or, for the *_ok forms, accept): used by
tests/integration/daemon_adversarial.sh and as fuzz seeds.

usage: hostile_gltf.py FORM OUT     (FORM: see FORMS below)
"""
import json
import struct
import sys

# one triangle: 3 VEC3 float positions (36 bytes) + 3 uint16 indices (6 bytes, padded to 8)
BIN = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0) + struct.pack("<3H", 0, 1, 2) + b"\0\0"


def doc():
    return {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "buffers": [{"byteLength": len(BIN)}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 36},
            {"buffer": 0, "byteOffset": 36, "byteLength": 6},
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"},
        ],
    }


def sparse(d, ioff=0, voff=0):
    # one substituted position: index (uint16) in view 1, value from view 0
    d["accessors"][0]["sparse"] = {
        "count": 1,
        "indices": {"bufferView": 1, "byteOffset": ioff, "componentType": 5123},
        "values": {"bufferView": 0, "byteOffset": voff},
    }
    return d


def glb(text, bin_=BIN):
    j = text.encode()
    j += b" " * (-len(j) % 4)
    b = bin_ + b"\0" * (-len(bin_) % 4)
    total = 12 + 8 + len(j) + 8 + len(b)
    return (struct.pack("<III", 0x46546C67, 2, total) + struct.pack("<II", len(j), 0x4E4F534A) + j
            + struct.pack("<II", len(b), 0x004E4942) + b)


def form(name):
    d = doc()
    if name == "ok":
        pass
    elif name == "sparse_ok":
        sparse(d)
    elif name == "sparse_indices_offset":  # the probe: indices.byteOffset 4e9
        sparse(d, ioff=4000000000)
    elif name == "sparse_values_offset":
        sparse(d, voff=4000000000)
    elif name == "sparse_count":
        sparse(d)["accessors"][0]["sparse"]["count"] = 1000
    elif name == "sparse_index_past_count":
        # index view holds 0,1,2; sparse count 2 reads 0,1 fine; a count-1 accessor makes 1 too big
        sparse(d)
        d["accessors"][0]["sparse"]["count"] = 2
        d["accessors"][0]["sparse"]["values"]["byteOffset"] = 0
        d["accessors"][0]["count"] = 3
        d["bufferViews"][1]["byteLength"] = 6
        bin_ = BIN[:36] + struct.pack("<3H", 0, 7, 2) + b"\0\0"
        d["meshes"][0]["primitives"][0].pop("indices")
        return glb(json.dumps(d), bin_)
    elif name == "stride_short":
        d["bufferViews"][0]["byteStride"] = 4
    elif name == "normalized_float":
        d["accessors"][0]["normalized"] = True
    elif name == "min_wrong_count":
        d["accessors"][0]["min"] = [0]
    elif name == "strip_one_vertex":  # found by fuzz_gltf_struct: assimp allocates 2^32 faces
        d["meshes"][0]["primitives"][0].pop("indices")
        d["meshes"][0]["primitives"][0]["mode"] = 5
        d["accessors"][0]["count"] = 1
        d["accessors"][0]["min"] = [0, 0, 0]
        d["accessors"][0]["max"] = [0, 0, 0]
    elif name == "position_vec2":
        d["accessors"][0]["type"] = "VEC2"
        d["accessors"][0].pop("min")
        d["accessors"][0].pop("max")
    elif name == "dup_key":  # "nodes" twice: the second would be what another parser reads
        t = json.dumps(d)
        return glb(t[:-1] + ', "nodes": [{"mesh": 0}, {"mesh": 0}]}')
    elif name == "nul_key":  # a decoy key with a NUL suffix before the real one
        t = json.dumps(d)
        return glb('{"children\\u0000": [], ' + t[1:])
    elif name == "trailing":
        return glb(json.dumps(d) + " {}")
    else:
        raise SystemExit("unknown form " + name)
    return glb(json.dumps(d))


FORMS = ["ok", "sparse_ok", "sparse_indices_offset", "sparse_values_offset", "sparse_count",
         "sparse_index_past_count", "stride_short", "normalized_float", "min_wrong_count",
         "strip_one_vertex", "position_vec2", "dup_key", "nul_key", "trailing"]

if __name__ == "__main__":
    if len(sys.argv) != 3 or sys.argv[1] not in FORMS:
        raise SystemExit(__doc__ + "FORMS: " + " ".join(FORMS))
    with open(sys.argv[2], "wb") as f:
        f.write(form(sys.argv[1]))
