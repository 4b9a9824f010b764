#!/usr/bin/python3
"""Compares what the twin's --trace logged with what `lec sniff --json` heard on the tap.

    sniff_compare.py TRACE SNIFF_JSONL MODE

MODE "same": the frames (queries and replies, in order) must be the same lists;
MODE "subsequence": every traced frame must appear in the sniff output in order
(noise may cut the controller's view of a query, never the sniffer's).
Also: every reply paired (not unsolicited) and decoded ("ID n ..."), no
frame split (a noise burst next to a frame whose bytes would complete it).
Prints counts as KEY=VALUE lines and "ok" or the first difference; exit 1 on a difference.
"""

import json
import re
import sys

trace_re = re.compile(r"(<-|->) ([0-9A-F]{2}(?: [0-9A-F]{2})*)  \|")
traced = []
with open(sys.argv[1]) as f:
    for line in f:
        m = trace_re.search(line)
        if m:
            traced.append(("query" if m.group(1) == "<-" else "reply", m.group(2)))

heard, stats, problems = [], None, []
counts = {"query": 0, "reply": 0, "noise": 0, "no_reply": 0, "short_silence": 0, "late": 0,
          "second_master": 0, "unsolicited": 0}
with open(sys.argv[2]) as f:
    for n, line in enumerate(f, 1):
        j = json.loads(line)
        if "stats" in j:
            stats = j["stats"]
            continue
        counts[j["dir"]] += 1
        for flag in j["flags"]:
            if flag in counts:
                counts[flag] += 1
        if j["dir"] in ("query", "reply"):
            heard.append((j["dir"], j["hex"]))
            if not j["explanation"].startswith("ID "):
                problems.append(f"line {n}: not decoded: {j['explanation']}")
        if j["dir"] == "reply" and "unsolicited" not in j["flags"] and "query_number" not in j:
            problems.append(f"line {n}: reply without its query")

for k, v in counts.items():
    print(f"{k}={v}")
print(f"traced={len(traced)}")
print(f"heard={len(heard)}")
print(f"stats={'yes' if stats else 'no'}")

mode = sys.argv[3]
if mode == "same":
    if traced != heard:
        for i, (a, b) in enumerate(zip(traced, heard)):
            if a != b:
                problems.append(f"frame {i}: twin logged {a}, sniff heard {b}")
                break
        else:
            problems.append(f"twin logged {len(traced)} frames, sniff heard {len(heard)}")
else:
    it = iter(heard)
    for i, t in enumerate(traced):
        if not any(t == h for h in it):
            problems.append(f"traced frame {i} {t} is not in the sniff output (in order)")
            break
if stats is None:
    problems.append("no statistics line at the end")
print("ok" if not problems else "\n".join(problems))
sys.exit(1 if problems else 0)
