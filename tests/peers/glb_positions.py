"""The vertex positions of a .glb's first mesh, for the peer tests' shell scripts to compare the
garments peers wrote (no dependency beyond Python's standard library)."""
import json
import struct


def glb_positions(path):
    # The first accessor of the first mesh's POSITION: enough to compare garments and find a pulled corner.
    data = open(path, "rb").read()
    jlen = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20:20 + jlen])
    binary = data[20 + jlen + 8:]
    acc = doc["accessors"][doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"]]
    view = doc["bufferViews"][acc["bufferView"]]
    start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    return [struct.unpack_from("<3f", binary, start + 12 * i) for i in range(acc["count"])]
