#!/bin/bash
# Issue 27's rest rule on one config: run it to rest (time T, run.json's summary), copy the
# run directory and resume the copy to 2T with the rest rule held off, then compare the two
# (rest_check.py: fronts and top at T and 2T, the sub-cell mass front from the checkpoints).
#   studies/benchmarks/two_phase/rest_run.sh CONFIG OUT_DIR H0 [FLOOR]
# (from the project root; FLOOR: 2 h_e on an erodible layer). Writes OUT_DIR, OUT_DIR_2T,
# their .log files and OUT_DIR_check.txt.
set -e
cfg=$1; out=$2; h0=$3; floor=${4:-0}
dpcollapse=${DPCOLLAPSE:-.venv/bin/dpcollapse}
[ -f "$out/run.json" ] || $dpcollapse run "$cfg" --out "$out" > "$out.log" 2>&1
T=$(python3 -c "import json; print(json.load(open('$out/run.json'))['summary']['t'])")
T2=$(python3 -c "print(2 * $T)")
rm -rf "${out}_2T"; cp -r "$out" "${out}_2T"
$dpcollapse run "$cfg" --out "${out}_2T" --resume --set time.end_time="$T2" \
    --set time.rest_speed=1e-9 --set time.rest_duration=100 > "${out}_2T.log" 2>&1
python3 "$(dirname "$0")/rest_check.py" "$out" "${out}_2T" "$h0" "$floor" | tee "${out}_check.txt"
