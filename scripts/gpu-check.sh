#!/usr/bin/env bash
# Checks and measures a raycast binary on this machine's GPU (or lavapipe): `raycast info`,
# `raycast selftest`, and the benchmarks that matter, into report.md and report.json.
# Needs only the binary (no Rust toolchain), bash, coreutils and python3 (standard library,
# for the report); the Vulkan loader is brought along where the system lacks one.
#
# On the machine that builds (bundles the script, a stripped binary and the Vulkan loader; with
# --mitsuba also peer_bench.py and Mitsuba 3's wheels for that python, trimmed to cuda_ad_rgb
# by scripts/trim-mitsuba.py: about 35 MB, PyPI needed):
#   scripts/gpu-check.sh --pack DIR [--mitsuba [--python 3.12]] [--lib-tests] [BINARY]
#                                              (BINARY: default target/release/raycast)
#   --lib-tests   also the library's release test binary (`cargo test --release -p raycast
#                 --lib --no-run`, beside BINARY in deps/): the kit then times each torus's
#                 kernel over buffers kept across casts (its kernel_ab measurement)
# On the machine with the GPU:
#   DIR/gpu-check.sh [--quick] [--out OUT] [--runs N] [--peer-bench peer_bench.py] DIR/raycast
#
#   --quick       small sizes (lavapipe, CI): 640x360, a 200,000-triangle big mesh, 100,000
#                 incoherent rays; default 3840x2160, 5,000,000 triangles, 2,000,000 rays
#   --out OUT     where the report goes (default ./gpu-check); raw outputs under OUT/raw
#   --runs N      timed runs per measurement, after one warm-up (default 5; --quick 1)
#   --peer-bench  ../shared/bench/peer_bench.py (default: DIR/peer_bench.py where packed):
#                 where python3 imports mitsuba, drjit and numpy (or DIR/wheels has them),
#                 Mitsuba 3's cuda_ad_rgb ray_intersect on the same torus and rays
# Exit status: 0 when the self-test passed and every step ran, 1 otherwise; 2 on bad usage.
set -uo pipefail

say() { printf '%s\n' "$*" >&2; }
usage() { say "usage: gpu-check.sh [--quick] [--out OUT] [--runs N] [--peer-bench FILE] BINARY | --pack DIR [--mitsuba [--python X.Y]] [--lib-tests] [BINARY]"; exit 2; }

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)

# The Vulkan loader, and libglvnd, without which NVIDIA's Vulkan driver (libGLX_nvidia.so.0)
# loads but creates no instance; containers that mount the driver may lack both.
kit_libs=(libvulkan.so.1 libGLdispatch.so.0 libGLX.so.0 libEGL.so.1 libGL.so.1 libOpenGL.so.0 libGLESv2.so.2)

# --- packing -------------------------------------------------------------------------------
pack() { # DIR BINARY MITSUBA PYTHON_VERSION LIB_TESTS
    local dir=$1 binary=${2:-$here/../target/release/raycast} mitsuba=$3 python=$4 lib_tests=$5
    [[ -x $binary ]] || { say "gpu-check: no binary at $binary (cargo build --release)"; exit 2; }
    mkdir -p "$dir/lib" || exit 2
    cp "${BASH_SOURCE[0]}" "$dir/gpu-check.sh" && cp "$binary" "$dir/raycast" || exit 2
    # The commit the kit was packed at, for the report ("-dirty" with uncommitted changes).
    local commit
    if commit=$(git -C "$here/.." rev-parse --short=12 HEAD 2>/dev/null); then
        git -C "$here/.." diff --quiet HEAD 2>/dev/null || commit+=-dirty
        echo "$commit" >"$dir/commit"
    fi
    # The cost model (docs/gpu.md#a-cost-model), where it was built beside the binary
    # (`cargo build --release -p raycast-benches --bin gpu_model`): its predictions for the
    # device go into the report beside the measurements.
    local model
    model=$(dirname "$binary")/gpu_model
    if [[ -x $model ]]; then
        cp "$model" "$dir/gpu_model" || exit 2
    else
        say "gpu-check: no gpu_model beside $binary: the report will have no predictions"
    fi
    if [[ $lib_tests == 1 ]]; then
        # The newest test binary of the library: the one with the kernel_ab measurement.
        local exe
        exe=$(ls -t "$(dirname "$binary")"/deps/raycast-???????????????? 2>/dev/null |
            while read -r f; do [[ -x $f ]] && "$f" --list 2>/dev/null | grep 'kernel_ab: test' >/dev/null && { echo "$f"; break; }; done)
        [[ -n $exe ]] || { say "gpu-check: no library test binary beside $binary (cargo test --release -p raycast --lib --no-run)"; exit 2; }
        cp "$exe" "$dir/raycast-lib-tests" || exit 2
    fi
    if command -v strip >/dev/null; then
        strip "$dir/raycast"
        [[ -x $dir/raycast-lib-tests ]] && strip "$dir/raycast-lib-tests"
        [[ -x $dir/gpu_model ]] && strip "$dir/gpu_model"
    else
        say "gpu-check: no strip; the binaries keep their symbols"
    fi
    local lib found
    for lib in "${kit_libs[@]}"; do
        found=$(ldconfig -p 2>/dev/null | awk -v l="$lib" '$1 == l {print $NF; exit}')
        if [[ -n $found ]]; then
            cp -L "$found" "$dir/lib/$lib" || exit 2
        else
            say "gpu-check: this machine has no $lib to bring"
        fi
    done
    if [[ $mitsuba == 1 ]]; then
        local peers=${PEER_BENCH_DIR:-$here/../../shared/bench} raw=$dir/wheels.download
        [[ -f $peers/peer_bench.py ]] || { say "gpu-check: no peer_bench.py in $peers (set PEER_BENCH_DIR)"; exit 2; }
        cp "$peers/peer_bench.py" "$dir/" || exit 2
        python3 -m pip download --quiet --no-deps --only-binary=:all: --python-version "$python" \
            --implementation cp --platform manylinux_2_28_x86_64 --platform manylinux_2_17_x86_64 \
            -d "$raw" mitsuba==3.9.1 drjit==1.5.0 || { say "gpu-check: cannot download Mitsuba's wheels"; exit 2; }
        mkdir -p "$dir/wheels" && mv "$raw"/drjit-*.whl "$dir/wheels/" &&
            python3 "$here/trim-mitsuba.py" "$raw"/mitsuba-*.whl "$dir/wheels" cuda_ad_rgb >&2 &&
            rm -r "$raw" || exit 2
    fi
    say "packed $dir: $(du -sh "$dir" | cut -f1)"
}

quick=0 out=gpu-check runs="" peer_bench="" binary="" pack_dir="" mitsuba=0 python=3.12 lib_tests=0
while [[ $# -gt 0 ]]; do
    case $1 in
        --pack) [[ $# -ge 2 ]] || usage; pack_dir=$2; shift ;;
        --mitsuba) mitsuba=1 ;;
        --lib-tests) lib_tests=1 ;;
        --python) [[ $# -ge 2 && $2 =~ ^3\.[0-9]+$ ]] || usage; python=$2; shift ;;
        --quick) quick=1 ;;
        --out) [[ $# -ge 2 ]] || usage; out=$2; shift ;;
        --runs) [[ $# -ge 2 && $2 =~ ^[1-9][0-9]*$ ]] || usage; runs=$2; shift ;;
        --peer-bench) [[ $# -ge 2 ]] || usage; peer_bench=$2; shift ;;
        -*) usage ;;
        *) [[ -z $binary ]] || usage; binary=$1 ;;
    esac
    shift
done
if [[ -n $pack_dir ]]; then
    pack "$pack_dir" "$binary" "$mitsuba" "$python" "$lib_tests"
    exit 0
fi
[[ -n $binary ]] || usage
[[ -x $binary ]] || { say "gpu-check: $binary is not an executable"; exit 2; }
command -v python3 >/dev/null || { say "gpu-check: python3 is needed to write the report"; exit 2; }
binary=$(cd "$(dirname "$binary")" && pwd)/$(basename "$binary")
if [[ $quick == 1 ]]; then
    size=640x360 big=200000 rays=100000 runs=${runs:-1} views=10 singles=2
else
    size=3840x2160 big=5000000 rays=2000000 runs=${runs:-5} views=100 singles=10
fi
raw=$out/raw
mkdir -p "$raw" || exit 2
rm -f "$raw"/*

# --- the Vulkan loader and driver ----------------------------------------------------------
export NODEVICE_SELECT=1
missing=()
for lib in "${kit_libs[@]}"; do
    ldconfig -p 2>/dev/null | awk -v l="$lib" '$1 == l {found = 1} END {exit !found}' || missing+=("$lib")
done
if [[ ${#missing[@]} -gt 0 ]]; then
    for lib in "$(dirname "$binary")/lib" "$here/lib"; do
        if [[ -e $lib/${missing[0]} ]]; then
            export LD_LIBRARY_PATH=$lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
            say "gpu-check: the system lacks ${missing[*]}; using $lib"
            break
        fi
    done
fi
if ! compgen -G '/usr/share/vulkan/icd.d/*.json' >/dev/null && ! compgen -G '/etc/vulkan/icd.d/*.json' >/dev/null &&
    [[ -z ${VK_DRIVER_FILES:-} && -f /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json ]]; then
    # Containers that mount the NVIDIA driver keep its ICD outside the loader's search path.
    export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
    say "gpu-check: using the NVIDIA driver's ICD, $VK_DRIVER_FILES"
fi

failed=()
step() { # NAME OUTFILE COMMAND...: runs a step, its stdout into OUTFILE, stderr into OUTFILE.err
    local name=$1 file=$2; shift 2
    say "== $name"
    local start=$SECONDS
    "$@" >"$file" 2>"$file.err"
    local rc=$?
    echo "$name $rc $((SECONDS - start))" >>"$raw/steps.txt"
    [[ $rc == 0 ]] || { failed+=("$name"); say "gpu-check: $name failed (exit $rc): $(tail -n 1 "$file.err")"; }
    return $rc
}

rc_total=0
if ! step info "$raw/info.txt" "$binary" info; then
    VK_LOADER_DEBUG=error,warn,driver "$binary" info >"$raw/info-loader.txt" 2>&1
    say "gpu-check: no adapter; the Vulkan loader's log is in $raw/info-loader.txt"
    rc_total=1
fi
step selftest "$raw/selftest.txt" "$binary" selftest

# --- workloads ------------------------------------------------------------------------------
work=$out/work
mkdir -p "$work/torus" "$work/big" "$work/lit"
step workloads "$raw/workloads.txt" bash -c '
    "$0" workload torus -o "$1/torus" --size "$3" &&
    "$0" workload spheres -o "$1/torus" --size "$3" &&
    "$0" workload torus -o "$1/big" --size "$3" --triangles "$2" &&
    "$0" workload lit-bunny -o "$1/lit"' "$binary" "$work" "$big" "$size"

bench() { # NAME ARGS...
    local name=$1; shift
    step "bench-$name" "$raw/bench-$name.jsonl" "$binary" bench --json --runs "$runs" "$@"
}
# Each mode and traversal in a process of its own: on the H200 a configuration measured after
# another in one process ran up to 6x slower on a large scene (docs/gpu.md, 2026-11-29).
bench_each() { # NAME MODES TRAVERSALS ARGS...
    local name=$1 modes=$2 traversals=$3; shift 3
    step "bench-$name" "$raw/bench-$name.jsonl" bash -c '
        binary=$1 runs=$2 modes=$3 traversals=$4; shift 4
        for mode in ${modes//,/ }; do
            for traversal in ${traversals//,/ }; do
                "$binary" bench --json --runs "$runs" --mode "$mode" --traversal "$traversal" "$@" || exit
            done
        done' bench "$binary" "$runs" "$modes" "$traversals" "$@"
}
# f64 where the adapter has it (raycast info: `shader f64: yes`).
torus_modes=gpu:f32
grep -q '^shader f64: *yes' "$raw/info.txt" && torus_modes=gpu:f32,gpu:f64
# Both BVH traversals where the adapter has packets (raycast info: `packet traversal: yes`).
traversals=per-ray
grep -q 'packet traversal: *yes' "$raw/info.txt" && traversals=packets,per-ray
bench_each torus "$torus_modes" "$traversals" "$work/torus/torus.json"
# The device's clocks every 50 ms through the big torus's frames, where nvidia-smi is there: a
# GPU idle through a frame's second-long build ran its kernel up to 5x slower (docs/gpu.md,
# 2026-11-30), most likely at lower clocks.
sampler=""
if command -v nvidia-smi >/dev/null; then
    nvidia-smi --query-gpu=timestamp,pstate,clocks.sm,clocks.mem,power.draw --format=csv,noheader \
        -lms 50 >"$raw/clocks.csv" 2>/dev/null &
    sampler=$!
fi
bench_each big gpu:f32 "$traversals" "$work/big/torus.json"
[[ -n $sampler ]] && kill "$sampler" 2>/dev/null
# A quarter of the size each way: where packets cost what the triangles seen do, not the rays
# (the H200's 5M torus at 960x540: 2.1 ms in packets, 0.38 per ray, docs/gpu.md).
bench_each big-small gpu:f32 "$traversals" "$work/big/torus.json" --size "$((${size%x*} / 4))x$((${size#*x} / 4))"
bench_each spheres gpu:f32 "$traversals" "$work/torus/spheres.json"
bench incoherent "$work/torus/torus.json" --rays "$rays" --mode gpu:f32
bench_each lit gpu:f32 "$traversals" "$work/lit/bunny.json" --lit

# The cost model's predictions for the same workloads, where the kit has gpu_model and the
# model has the device's parameters (GPU_MODEL_DEVICE names them: h200, rtx4090).
model_device=${GPU_MODEL_DEVICE:-}
if [[ -z $model_device ]]; then
    case $(grep -i '^adapter:' "$raw/info.txt") in
        *H200*) model_device=h200 ;;
        *4090*) model_device=rtx4090 ;;
    esac
fi
predict() { # NAME ARGS...
    local name=$1; shift
    step "model-$name" "$raw/model-$name.jsonl" "$here/gpu_model" "$@" --device "$model_device" --json
}
if [[ -x $here/gpu_model && -n $model_device ]]; then
    quarter=$((${size%x*} / 4))x$((${size#*x} / 4))
    predict torus "$work/torus/torus.json" --size "$size" --traversal both
    grep -q '^shader f64: *yes' "$raw/info.txt" &&
        predict torus-f64 "$work/torus/torus.json" --size "$size" --traversal both --f64
    predict big "$work/big/torus.json" --size "$size" --traversal both
    predict big-small "$work/big/torus.json" --size "$quarter" --traversal both
    predict spheres "$work/torus/spheres.json" --size "$size" --traversal both
    predict incoherent "$work/torus/torus.json" --rays "$rays" --traversal per-ray
else
    say "gpu-check: no predictions (the kit has no gpu_model, or the model has no parameters for this device: GPU_MODEL_DEVICE=h200|rtx4090)"
fi

# Adaptive precision is two passes (bench times single frames): whole renders, wall time,
# f32 and adaptive in turn, each round alternating which goes first.
adaptive_times() {
    local rounds=$((runs < 3 ? 3 : runs)) k mode t0
    for ((k = 0; k < rounds; k++)); do
        for mode in $( ((k % 2)) && echo "adaptive f32" || echo "f32 adaptive"); do
            t0=$(date +%s.%N)
            "$binary" render "$work/torus/torus.json" --size "$size" --precision "$mode" \
                --outputs id --format npy -o "$work/render-$mode" >/dev/null || return 1
            echo "$mode $(date +%s.%N) $t0"
        done
    done
}
step adaptive "$raw/adaptive.txt" adaptive_times

# A dataset (docs/datasets.md#how-fast): the views of an orbit as one batch, against single
# renders (each a process: device, compile, render, files) and the kernel's rate on the same
# views (bench --orbit: each view's camera once a run).
views_times() {
    local t0 k
    t0=$(date +%s.%N)
    "$binary" render "$work/lit/bunny.json" --orbit "$views" --size 640x360 -o "$work/views" >/dev/null || return 1
    echo "batch $(date +%s.%N) $t0"
    for ((k = 0; k < singles; k++)); do
        t0=$(date +%s.%N)
        "$binary" render "$work/lit/bunny.json" --size 640x360 -o "$work/single" >/dev/null || return 1
        echo "single $(date +%s.%N) $t0"
    done
}
step views "$raw/views.txt" views_times
bench views "$work/lit/bunny.json" --orbit "$views" --size 640x360

# The kernel over buffers kept across casts and dispatched back to back, as a session of
# queries or a viewer has them: each of bench's frames builds and uploads the scene first, and
# an H200 left idle that long (a second for the 5M torus) ran the next kernel up to 5x slower
# (docs/gpu.md, 2026-11-30).
kept_times() {
    local name scene flag line traversal
    for name in torus torus-f64 big; do
        scene=$work/torus/torus.json flag=""
        [[ $name == big ]] && scene=$work/big/torus.json
        [[ $name == torus-f64 ]] && { grep -q '^shader f64: *yes' "$raw/info.txt" || continue; flag=--f64; }
        for traversal in ${traversals//,/ }; do
            line=$(RAYCAST_MEASURE="$scene $flag --traversal $traversal --rounds $runs builtin" \
                "$here/raycast-lib-tests" kernel_ab --ignored --nocapture 2>&1 | grep '^builtin: median') || return 1
            set -- $line
            echo "$name $traversal $3"
        done
    done
}
[[ -x $here/raycast-lib-tests ]] && step kept "$raw/kept.txt" kept_times

[[ -z $peer_bench && -f $here/peer_bench.py ]] && peer_bench=$here/peer_bench.py
if [[ -n $peer_bench ]]; then
    if ! python3 -c 'import mitsuba, drjit' 2>/dev/null && compgen -G "$here/wheels/*.whl" >/dev/null; then
        python3 -m pip install --quiet --no-index --no-deps --no-compile --target "$work/site" "$here"/wheels/*.whl &&
            export PYTHONPATH=$work/site${PYTHONPATH:+:$PYTHONPATH}
    fi
    if python3 -c 'import mitsuba, drjit, numpy' 2>/dev/null; then
        peer() {
            python3 "$peer_bench" --make-torus "$work/peer-torus.obj" >/dev/null &&
                sed -e 's/"ply": "torus.ply"/"obj": "peer-torus.obj"/' "$work/torus/torus.json" >"$work/peer-torus.json" &&
                "$binary" bench "$work/peer-torus.json" --json --runs "$runs" >"$raw/bench-peer-torus.jsonl" &&
                python3 "$peer_bench" "$work/peer-torus.obj" --width "${size%x*}" --height "${size#*x}" \
                    --peers mitsuba_cuda --workloads mesh,spheres --repeats "$runs" --wait-idle 0 \
                    --out "$work/peers"
        }
        step mitsuba "$raw/mitsuba.jsonl" peer
    else
        say "gpu-check: python3 cannot import mitsuba, drjit and numpy: no Mitsuba figures"
        echo "mitsuba: python3 cannot import mitsuba, drjit and numpy" >"$raw/mitsuba.skipped"
    fi
fi

# --- the report -----------------------------------------------------------------------------
python3 - "$out" "$binary" "$size" "$runs" "$views" "$here" <<'EOF'
import datetime, json, os, platform, statistics, sys

out, binary, size, runs, n_views, here = sys.argv[1:7]
n_views = int(n_views)
raw = os.path.join(out, "raw")

def text(name):
    try:
        return open(os.path.join(raw, name)).read()
    except OSError:
        return ""

def rows(name):
    return [json.loads(l) for l in text(name).splitlines() if l.startswith("{")]

steps = [l.split() for l in text("steps.txt").splitlines()]
selftest = text("selftest.txt").splitlines()
summary = next((l for l in reversed(selftest) if l.startswith("selftest:")), "selftest: no summary")
bench = {name: rows("bench-%s.jsonl" % name)
         for name in ("torus", "big", "big-small", "spheres", "incoherent", "lit", "peer-torus",
                      "views")}
# The cost model's predictions, by the bench workload they predict (torus-f64: the torus in f64).
model = {name: rows("model-%s.jsonl" % name)
         for name in ("torus", "torus-f64", "big", "big-small", "spheres", "incoherent")}

def predicted(name, r):
    # The model's ms for bench row r of workload name: same precision and traversal (a ray
    # list, per ray: the traversal it chooses for incoherent rays).
    f64 = r["mode"].startswith("gpu:f64")
    rows_ = model.get(name + "-f64" if f64 and name == "torus" else name, [])
    t = r.get("traversal", "auto")
    t = "per-ray" if t == "auto" else t
    return next((m["predicted_ms"] for m in rows_ if m["traversal"] == t), None)
views = {"batch": [], "single": []}
for line in text("views.txt").splitlines():
    kind, end, start = line.split()
    views[kind].append(float(end) - float(start))
adaptive = {"f32": [], "adaptive": []}
for line in text("adaptive.txt").splitlines():
    mode, end, start = line.split()
    adaptive[mode].append(float(end) - float(start))
medians = {m: statistics.median(t) for m, t in adaptive.items() if t}
peers = [json.loads(l) for l in text("mitsuba.jsonl").splitlines() if l.startswith('{"peer"')]

def by_mode(name, mode):
    return next((r for r in bench[name] if r["mode"] == mode), None)

def config(r):
    # The mode, and the traversal where one was asked for.
    t = r.get("traversal", "auto")
    return r["mode"] if t == "auto" else "%s %s" % (r["mode"], t)

f32, f64 = by_mode("torus", "gpu:f32:robust"), by_mode("torus", "gpu:f64:robust")
info = dict(l.split(":", 1) for l in text("info.txt").splitlines() if ":" in l)
commit_file = os.path.join(here, "commit")
report = {
    "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
    "device": info.get("adapter", "").strip() or None,
    "driver": info.get("driver info", "").strip() or None,
    "commit": open(commit_file).read().strip() if os.path.exists(commit_file) else None,
    "host": platform.node(), "binary": binary, "size": size, "runs": int(runs),
    "info": text("info.txt").splitlines(), "selftest": {"lines": selftest, "summary": summary},
    "steps": {s[0]: {"exit": int(s[1]), "seconds": int(s[2])} for s in steps},
    "bench": bench, "adaptive_render_s": medians, "mitsuba": peers,
    # Each workload by mode and traversal: what docs/gpu/reports/ keeps at a glance.
    "workloads": [{"workload": name, "mode": r["mode"], "traversal": r.get("traversal", "auto"),
                   "packets": r.get("packets"),
                   "kernel_ms": r["trace_gpu_s"] and r["trace_gpu_s"] * 1e3,
                   "grays_per_s": r["mrays_per_s"] / 1e3, "whole_ms": r["trace_s"] * 1e3,
                   "predicted_ms": predicted(name, r)}
                  for name, rs in bench.items() for r in rs],
    "model": model,
    "views": {
        "views": n_views,
        "batch_s": views["batch"][0] if views["batch"] else None,
        "single_s": statistics.median(views["single"]) if views["single"] else None,
        "loop_over_batch": n_views * statistics.median(views["single"]) / views["batch"][0]
            if views["batch"] and views["single"] else None,
        "batch_over_kernel": bench["views"][0]["rays"] / views["batch"][0] / 1e6 / bench["views"][0]["mrays_per_s"]
            if views["batch"] and bench["views"] else None,
    },
    "clocks": [[field.strip() for field in line.split(",")] for line in text("clocks.csv").splitlines()],
    "kept_kernel_ms": {"%s %s" % (name, traversal): float(s) * 1e3 for name, traversal, s in
                       (l.split() for l in text("kept.txt").splitlines())},
    "cost": {
        "f64_over_f32_kernel": f64["trace_gpu_s"] / f32["trace_gpu_s"]
            if f32 and f64 and f32["trace_gpu_s"] and f64["trace_gpu_s"] else None,
        "adaptive_over_f32_render": medians["adaptive"] / medians["f32"]
            if len(medians) == 2 else None,
    },
}
json.dump(report, open(os.path.join(out, "report.json"), "w"), indent=1)

def fmt(x, spec):
    return "-" if x is None else format(x, spec)

md = ["# raycast gpu-check, %s" % report["date"], "",
      "`%s` on %s, %s, %s run%s after a warm-up." % (os.path.basename(binary), report["host"],
                                                   size, runs, "" if runs == "1" else "s"), "",
      "## raycast info", "", "```", *report["info"], "```", "",
      "## raycast selftest", "", "```", *selftest, "```", "",
      "## Benchmarks", "",
      "| workload | mode | rays | Grays/s | kernel ms | wall ms | secondary Grays/s | hit % |",
      "|---|---|---:|---:|---:|---:|---:|---:|"]
names = {"torus": "torus, %s triangles", "big": "big torus, %s triangles",
         "big-small": "big torus, %s triangles, a quarter of the size",
         "spheres": "100 spheres", "incoherent": "incoherent rays, torus (%s triangles)",
         "lit": "lit course bunny (--lit)", "peer-torus": "peers' torus.obj, %s triangles",
         "views": "course bunny, %d orbit views at 640x360 (the dataset's)" % n_views}

def workload(name, r):
    return names[name] % format(r["triangles"], ",") if "%s" in names[name] else names[name]

for name, rs in bench.items():
    for r in rs:
        what = workload(name, r)
        secondary = r.get("secondary_mrays_per_s")
        md.append("| %s | %s | %s | %s | %s | %s | %s | %.1f |" % (
            what, config(r), format(r["rays"], ","), fmt(r["mrays_per_s"] / 1e3, ".3g"),
            fmt(r["trace_gpu_s"] and r["trace_gpu_s"] * 1e3, ".2f"), fmt(r["trace_s"] * 1e3, ".2f"),
            fmt(secondary and secondary / 1e3, ".3g"), 100 * r["hit_fraction"]))
md += ["", "Grays/s from GPU timestamps where the device has them (kernel time), else wall time "
       "(the wall ms of incoherent rays: the cast, upload and readback included).", "",
       "Cost against f32: f64 kernel %s x (torus); adaptive whole render %s x (torus, %s, "
       "medians of %d and %d renders)." % (
           fmt(report["cost"]["f64_over_f32_kernel"], ".2f"),
           fmt(report["cost"]["adaptive_over_f32_render"], ".2f"), size,
           len(adaptive["adaptive"]), len(adaptive["f32"]))]
v = report["views"]
md += ["", "Dataset (lit bunny, 640x360): %d views (`--orbit %d`) in %s s; a single render "
       "%s s, so a loop of single renders takes %s x the batch's time; the batch at %s x the "
       "kernel's rate on the same views (bench --orbit)." % (
           n_views, n_views, fmt(v["batch_s"], ".2f"), fmt(v["single_s"], ".3f"),
           fmt(v["loop_over_batch"], ".1f"), fmt(v["batch_over_kernel"], ".2f"))]

def ms(s):
    return fmt(s and s * 1e3, ".2f")

md += ["", "## Stages of the whole cast", "",
       "| workload | mode | trace ms | kernel ms | whole/kernel | write ms | wait ms | convert ms "
       "| GPU copy ms | MB read back |", "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
for name, rs in bench.items():
    for r in rs:
        if r.get("readback_bytes") is None:
            continue
        md.append("| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |" % (
            workload(name, r), config(r), ms(r["trace_s"]), ms(r["trace_gpu_s"]),
            fmt(r["whole_over_kernel"], ".2f"), ms(r["write_s"]), ms(r["wait_s"]),
            ms(r["convert_s"]), ms(r["copy_s"]), fmt(r["readback_bytes"] / 1e6, ".1f")))
md += ["", "The trace (`trace_s`, wall) against its kernel (GPU timestamps); of the trace, the inputs "
       "written, the host's wait for the device and the conversion of what was read back; the GPU's "
       "copy to host-mapped memory where measured. Medians of the runs; the dataset's row sums its "
       "views. Ray lists (`--rays`) report no parts."]
if report["kept_kernel_ms"]:
    md += ["", "The kernel over buffers kept across casts, dispatched back to back (the library's "
           "`kernel_ab`, each traversal the device has, median of %s rounds): %s; in the tables "
           "above each frame builds and uploads the scene first." % (runs, "; ".join(
               "%s %.2f ms" % (name, ms) for name, ms in report["kept_kernel_ms"].items()))]
predictions = [w for w in report["workloads"] if w["predicted_ms"] is not None]
if predictions:
    device = next((m["device"] for rs in model.values() for m in rs), "?")
    md += ["", "## The cost model against the kernel (gpu_model --device %s)" % device, "",
           "| workload | mode | traversal | predicted ms | measured ms | measured / predicted |",
           "|---|---|---|---:|---:|---:|"]
    for w in predictions:
        measured = w["kernel_ms"] if w["kernel_ms"] is not None else w["whole_ms"]
        md.append("| %s | %s | %s | %.3f | %.2f | %.1f |" % (
            w["workload"], w["mode"], w["traversal"], w["predicted_ms"], measured,
            measured / w["predicted_ms"]))
    md += ["", "Measured: kernel ms (GPU timestamps), the incoherent rays' whole cast (upload and "
           "readback included, which the model leaves out)."]
if peers:
    md += ["", "## Mitsuba 3 (peer_bench.py)", "", "| peer | workload | build s | trace s | Grays/s |",
           "|---|---|---:|---:|---:|"]
    md += ["| %s %s | %s | %s | %s | %.3g |" % (p["peer"], p.get("version", ""), p["workload"],
           p["build_s"], p["trace_s"], p["mrays_per_s"] / 1e3) for p in peers
           if "error" not in p and "mrays_per_s" in p]
    md += ["| %s | %s | error: %s | | |" % (p["peer"], p["workload"], p["error"][:80])
           for p in peers if "error" in p]
failed = [s[0] for s in steps if s[1] != "0"]
md += ["", "Steps: " + ", ".join("%s %s s%s" % (s[0], s[2], "" if s[1] == "0" else " (FAILED, exit %s)" % s[1])
                                for s in steps), ""]
open(os.path.join(out, "report.md"), "w").write("\n".join(md))
print(summary)
print("failed steps: " + (", ".join(failed) or "none"))
EOF
[[ ${#failed[@]} == 0 && $rc_total == 0 ]] || { say "gpu-check: failed: ${failed[*]}"; exit 1; }
say "gpu-check: wrote $out/report.md and $out/report.json"
