#!/bin/bash
# The shipped Prometheus configuration, alerting rules and Grafana dashboard (compose/prometheus):
# promtool checks the configuration and the rules and runs the rules' tests (alerts_test.yml); the
# dashboard is valid JSON; and every metric the rules and the dashboard query is one
# docs/operations.md documents, so that a metric renamed in a program fails here.
# Usage: prometheus_config_test.sh SOURCE_DIR PROMTOOL
set -euo pipefail
root=$1
promtool=$2
dir=$root/compose/prometheus

"$promtool" check config "$dir/prometheus.yml"
"$promtool" check rules "$dir/alerts.yml"
(cd "$dir" && "$promtool" test rules alerts_test.yml)

python3 - "$dir/alerts.yml" "$dir/grafana-dashboard.json" "$root/docs/operations.md" <<'PY'
import json, re, sys
alerts, dashboard, docs = sys.argv[1:4]
exprs = [open(alerts, encoding="utf-8").read()]
for panel in json.load(open(dashboard, encoding="utf-8"))["panels"]:
    exprs += [target["expr"] for target in panel["targets"]]
documented = set(re.findall(r"`((?:urslink|process)_[a-z_]+)`", open(docs, encoding="utf-8").read()))
used = set()
for expr in exprs:
    for name in re.findall(r"\b((?:urslink|process)_[a-z_]+)", expr):
        used.add(re.sub(r"_(bucket|sum|count)$", "", name) if name.endswith(("_bucket", "_sum", "_count")) and
                 "_seconds_" in name else name)
missing = sorted(used - documented)
if missing:
    sys.exit("queried but not documented in docs/operations.md: " + ", ".join(missing))
print(f"{len(used)} metrics queried, each documented")
PY
