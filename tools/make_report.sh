#!/usr/bin/env bash
# make_report.sh - writes report/accuracy.md and report/*.svg (issue 4,
# `make report`): builds the report generator tools/report_accuracy.c
# against the release library and runs it.  Takes a few minutes on 2 cores;
# every number in the report is measured by that run.
set -eu
cd "$(dirname "$0")/.."
B=${B:-build/release}
make --no-print-directory MODE=release B="$B" "$B/tools/report_accuracy"
mkdir -p report
"$B/tools/report_accuracy" report
