#!/usr/bin/env python3
"""CTest evaluation.report_schema: evaluation/report.schema.json accepts the report.json of a run
(every REPORT given), refuses what the readers of a report could not read (a missing score, an
unknown field, a share above 1), and names every metric the regression suites guard, so that a
renamed field fails here rather than as a silently missing metric.
Usage: report_schema_test.py SOURCE_DIR REPORT..."""
import copy
import glob
import json
import os
import sys

import jsonschema
import yaml

root, reports = sys.argv[1], sys.argv[2:]
schema = json.load(open(os.path.join(root, "evaluation", "report.schema.json")))
jsonschema.Draft202012Validator.check_schema(schema)
validator = jsonschema.Draft202012Validator(schema)
assert reports, "FAIL: no report given"
for path in reports:
    errors = list(validator.iter_errors(json.load(open(path))))
    assert not errors, f"FAIL: {path}: {errors[0].json_path}: {errors[0].message}"
print(f"{len(reports)} report(s) valid")

report = json.load(open(reports[0]))


def broken(change):
    doc = copy.deepcopy(report)
    change(doc)
    return doc


def drop_f1(d):
    del d["ground_segmentation"]["gmrf_mincut"]["f1"]


def unknown(d):
    d["height_recovery"]["after"]["median_m"] = 1.0


def share_above_one(d):
    d["boundary_coverage"] = 1.5


def unknown_top_level(d):
    d["extra"] = 0


for name, change in [("a missing F1", drop_f1), ("an unknown error field", unknown),
                     ("coverage above 1", share_above_one), ("an unknown top-level field", unknown_top_level)]:
    assert list(validator.iter_errors(broken(change))), f"FAIL: {name} was accepted"
print("broken reports refused")


def resolves(path):
    """Does the dotted metric path name a field of the schema? (through properties, refs and
    allOf; keys of open maps such as by_object are taken by additionalProperties)"""
    node = schema
    for key in path.split("."):
        while True:
            if "$ref" in node:
                node = schema["$defs"][node["$ref"].split("/")[-1]]
            elif "allOf" in node and key not in node.get("properties", {}):
                node = {"properties": {k: v for part in node["allOf"] for k, v in
                                       (schema["$defs"][part["$ref"].split("/")[-1]].get("properties", {})).items()}}
            else:
                break
        props = node.get("properties", {})
        if key in props:
            node = props[key]
        elif isinstance(node.get("additionalProperties"), dict):
            node = node["additionalProperties"]
        else:
            return False
    return True


metrics = 0
for suite in sorted(glob.glob(os.path.join(root, "evaluation", "suites", "*.yaml"))):
    spec = yaml.safe_load(open(suite))
    for name, rule in (spec.get("metrics") or {}).items():
        assert resolves(name), f"FAIL: {suite}: metric {name} is not a field of report.schema.json"
        if isinstance(rule, dict) and "count" in rule:
            assert resolves(rule["count"]), f"FAIL: {suite}: count {rule['count']} is not a field"
        metrics += 1
assert metrics > 0, "FAIL: no suite metric found"
assert not resolves("height_recovery.after.median_m"), "FAIL: an unknown field resolved"
print(f"{metrics} suite metrics named in the schema")
print("PASS")
