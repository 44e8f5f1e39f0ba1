#!/usr/bin/env python3
"""CTest scenes.truth_schema: scenes/truth.schema.json accepts every committed sidecar (the
generator's scenes and the hand-written examples) and refuses what the loader refuses in shape:
a missing field, an unknown field, a footprint of two points, a terrain kind not known.
Usage: truth_schema_test.py SOURCE_DIR"""
import copy
import glob
import json
import os
import sys

import jsonschema

root = sys.argv[1]
schema = json.load(open(os.path.join(root, "scenes", "truth.schema.json")))
jsonschema.Draft202012Validator.check_schema(schema)
validator = jsonschema.Draft202012Validator(schema)
files = sorted(glob.glob(os.path.join(root, "scenes", "library", "*.truth.json")) +
               glob.glob(os.path.join(root, "scenes", "examples", "*.truth.json")))
assert len(files) >= 4, f"FAIL: expected the library's and the examples' sidecars, found {files}"
for f in files:
    errors = list(validator.iter_errors(json.load(open(f))))
    assert not errors, f"FAIL: {f}: {errors[0].message}"
print(f"{len(files)} committed sidecars valid")

example = json.load(open(os.path.join(root, "scenes", "examples", "courtyard.truth.json")))
def broken(change):
    doc = copy.deepcopy(example)
    change(doc)
    return doc
cases = {
    "no path": broken(lambda d: d.pop("path")),
    "unknown field": broken(lambda d: d.__setitem__("colour", "red")),
    "unknown object field": broken(lambda d: d["objects"][0].__setitem__("height", 3)),
    "two-point footprint": broken(lambda d: d["objects"][0].__setitem__("footprint", [[0, 0], [1, 0]])),
    "terrain kind": broken(lambda d: d["terrain"].__setitem__("kind", "mesh")),
    "hfield without its grid": broken(lambda d: d["terrain"].__setitem__("kind", "hfield")),
    "one waypoint": broken(lambda d: d["path"].__setitem__("waypoints", [[0, 0]])),
}
for name, doc in cases.items():
    assert list(validator.iter_errors(doc)), f"FAIL: the schema accepts a sidecar with {name}"
print(f"{len(cases)} broken sidecars refused")
print("PASS")
