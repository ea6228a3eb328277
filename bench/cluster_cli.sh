#!/usr/bin/env bash
# Issue 13's "done when", by hand: case3 in process, then against a `dask scheduler` and two
# `dask worker` processes started from the command line, one killed (SIGKILL) after two
# chunks finished; then an in-process build killed after its first chunk and resumed.
# Prints whether every roadmap file equals the in-process one. Needs mpd-pin and dask on PATH.
set -u
export MPLBACKEND=Agg
D=$(mktemp -d)
PORT=$(python -c "import socket; s=socket.socket(); s.bind(('127.0.0.1',0)); print(s.getsockname()[1])")
partials() { ls "$1" 2>/dev/null | wc -l; }

mpd-pin run case3 --evaluation eager --out "$D/ref" --quiet --no-replay --cache "$D/ref.npz" >/dev/null

dask scheduler --host 127.0.0.1 --port "$PORT" --dashboard-address :0 >"$D/sched.log" 2>&1 &
SCHED=$!
sleep 3
dask worker "tcp://127.0.0.1:$PORT" --nthreads 1 --no-nanny >"$D/w1.log" 2>&1 &
W1=$!
dask worker "tcp://127.0.0.1:$PORT" --nthreads 1 --no-nanny >"$D/w2.log" 2>&1 &
W2=$!
sleep 4
mpd-pin run case3 --evaluation eager --out "$D/cl" --quiet --no-replay --cache "$D/cl.npz" \
    --scheduler "tcp://127.0.0.1:$PORT" &
RUN=$!
while [ "$(partials "$D/cl.npz.partial")" -lt 2 ] && kill -0 $RUN 2>/dev/null; do sleep 0.05; done
echo "killing worker $W2 after $(partials "$D/cl.npz.partial") chunks"
kill -9 $W2
wait $RUN
echo "cluster run exit $?"
kill $W1 $SCHED 2>/dev/null
wait 2>/dev/null

mpd-pin run case3 --evaluation eager --out "$D/rs" --quiet --no-replay --cache "$D/rs.npz" &
RUN=$!
while [ "$(partials "$D/rs.npz.partial")" -lt 1 ] && kill -0 $RUN 2>/dev/null; do sleep 0.05; done
kill -9 $RUN 2>/dev/null
wait $RUN 2>/dev/null
echo "in-process build killed after $(partials "$D/rs.npz.partial") chunk(s); resuming"
mpd-pin run case3 --evaluation eager --out "$D/rs" --quiet --no-replay --cache "$D/rs.npz"

python - "$D" <<'PY'
import json, sys
import numpy as np
d = sys.argv[1]
ref = np.load(f"{d}/ref.npz")
for name in ("cl", "rs"):
    got = np.load(f"{d}/{name}.npz")
    same = sorted(ref.files) == sorted(got.files) and all(
        np.array_equal(ref[k], got[k]) for k in ref.files)
    res = json.load(open(f"{d}/{name}/result.json"))
    print(f"{name}: file equal to the in-process one: {same}; compute {res['compute']}; "
          f"chunks reused {res['roadmap']['chunks_reused']}; total {res['total_energy']:.6g} J")
PY
