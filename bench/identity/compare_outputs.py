#!/usr/bin/env python3
"""Compares two directories of outputs from outputs.sh: images bit for bit (multi-part EXRs
written through OpenImageIO by pixels, with idiff), cache files but for their UUID, statistics
JSON without timing fields. Prints each difference; exit 1 if any."""
import json, os, re, subprocess, sys

TIMING = re.compile(r"(seconds|_ms$|per_second|^threads$)")

def strip(j):
    if isinstance(j, dict):
        return {k: strip(v) for k, v in j.items() if not TIMING.search(k)}
    if isinstance(j, list):
        return [strip(v) for v in j]
    return j

def main(a, b):
    bad = 0
    for root, _, files in os.walk(a):
        for f in sorted(files):
            pa = os.path.join(root, f)
            rel = os.path.relpath(pa, a)
            pb = os.path.join(b, rel)
            if not os.path.exists(pb):
                print("missing", rel); bad += 1; continue
            da, db = open(pa, "rb").read(), open(pb, "rb").read()
            if da == db:
                continue
            if f.endswith(".json"):
                ja = strip(json.loads(da.decode().replace(os.path.abspath(a), "DIR")))
                jb = strip(json.loads(db.decode().replace(os.path.abspath(b), "DIR")))
                if ja != jb:
                    print("json differs", rel)
                    for k in sorted(set(ja) | set(jb)):
                        if ja.get(k) != jb.get(k):
                            print("   ", k, ":", json.dumps(ja.get(k))[:300], "->", json.dumps(jb.get(k))[:300])
                    bad += 1
            elif f.endswith(".exr"):
                r = subprocess.run(["idiff", "-a", "-fail", "0", "-warn", "0", pa, pb],
                                   capture_output=True, text=True)
                if r.returncode != 0:
                    print("image differs", rel); bad += 1
            elif ".vdb" in f:
                diff = [i for i in range(min(len(da), len(db))) if da[i] != db[i]]
                # The header's UUID (bytes 21-57), and the trailing checksum that covers it.
                if len(da) != len(db) or any(64 <= i < len(da) - 8 for i in diff):
                    print("cache file differs", rel, len(da), len(db), diff[:5]); bad += 1
            else:
                print("differs", rel); bad += 1
    print("%s: %s" % (b, "identical" if not bad else "%d differences" % bad))
    return 1 if bad else 0

sys.exit(main(sys.argv[1], sys.argv[2]))
