#!/usr/bin/env bash
# raycast side by side with the CPU ray casters of peer_bench.py (open3d, embreex, trimesh,
# mitsuba), on the same primary rays, all measured in this one run:
#   1. the 518,400-triangle displaced torus at 1920x1080 (one ray per pixel centre),
#   2. 100 analytic spheres (seed 0) with the same camera.
# Prints a table of build seconds and Mrays/s for raycast and every peer, with the ratios
# raycast/peer. Not part of CI: it needs network access (PyPI) the first time, and minutes.
#
# Usage: benches/peers.sh            (from anywhere; works in the repository's target/)
# Environment:
#   PEER_BENCH_DIR  folder holding peer_bench.py and requirements.txt
#                   (default: the repository's ../shared/bench)
#   RUNS            timed runs per measurement, after one warm-up (default 5)
#   WAIT_IDLE       seconds to wait, before each measurement, for other processes to go
#                   idle (shared machines; default 120, 0 to skip)
#   PEER_ARGS       extra arguments for peer_bench.py (e.g. "--peers open3d,mitsuba_llvm")
#   RAYCAST_ARGS    extra arguments for raycast bench (e.g. "--accel auto,brute-force")
# Outputs (under target/bench/): torus.obj, torus.json, spheres.json (raycast scene),
# raycast-*.jsonl, peers-*.jsonl, peers/ (depth images, the peers' spheres.json), table.md.
set -euo pipefail

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$repo"
peer_dir=${PEER_BENCH_DIR:-$repo/../shared/bench}
runs=${RUNS:-5}
wait_idle=${WAIT_IDLE:-120}
read -r -a peer_args <<<"${PEER_ARGS:-}"
read -r -a raycast_args <<<"${RAYCAST_ARGS:-}"
venv=target/peers-venv
out=target/bench
# The peers' camera (/work/shared/bench/README.md).
width=1920 height=1080 vfov=40
eye=(0 -3.0 2.5) lookat=(0 0 0) up=(0 0 1)

say() { printf '%s\n' "$*" >&2; }
die() { say "peers.sh: $*"; exit 1; }

[[ -f $peer_dir/peer_bench.py && -f $peer_dir/requirements.txt ]] ||
    die "no peer_bench.py and requirements.txt in $peer_dir (set PEER_BENCH_DIR)"
mkdir -p "$out/peers"

# --- Python peers, in a venv under target/ -------------------------------------------------
if [[ ! -x $venv/bin/python ]]; then
    say "creating $venv"
    python3 -m venv "$venv" || die "python3 -m venv failed (Debian: apt-get install python3-venv)"
fi
py=$venv/bin/python
stamp=$venv/requirements.installed
if ! cmp -s "$peer_dir/requirements.txt" "$stamp"; then
    say "installing $peer_dir/requirements.txt into $venv"
    if "$py" -m pip install --quiet -r "$peer_dir/requirements.txt"; then
        cp "$peer_dir/requirements.txt" "$stamp"
    else
        # One at a time, so a peer that cannot be installed leaves the others measured
        # (peer_bench.py reports a peer it cannot import as an error line).
        say "installing all at once failed; installing one by one"
        grep -Ev '^[[:space:]]*(#|$)' "$peer_dir/requirements.txt" | while read -r req; do
            "$py" -m pip install --quiet "$req" || say "warning: could not install $req"
        done
    fi
fi
"$py" -c "import numpy" 2>/dev/null || die "numpy is not installed in $venv: peer_bench.py needs it"

# open3d's pybind imports libusb-1.0.so.0.
if ! ldconfig -p 2>/dev/null | grep -q 'libusb-1\.0\.so\.0'; then
    if [[ $(id -u) == 0 ]] && command -v apt-get >/dev/null; then
        say "installing libusb-1.0-0 (for open3d)"
        apt-get install -y -qq libusb-1.0-0 >/dev/null 2>&1 ||
            { apt-get update -qq >/dev/null && apt-get install -y -qq libusb-1.0-0 >/dev/null; } ||
            say "warning: could not install libusb-1.0-0; open3d will fail to import"
    else
        say "warning: libusb-1.0-0 is missing (apt-get install libusb-1.0-0); open3d will fail to import"
    fi
fi

# --- raycast, release build ----------------------------------------------------------------
say "building raycast (release)"
cargo build --release --quiet
raycast=target/release/raycast

# --- workloads -----------------------------------------------------------------------------
if [[ ! -f $out/torus.obj ]]; then
    say "making $out/torus.obj"
    "$py" "$peer_dir/peer_bench.py" --make-torus "$out/torus.obj" >/dev/null
fi

# A raycast scene with the peers' camera; objects: a JSON list. Args: FILE OBJECTS.
write_scene() {
    "$py" - "$1" "$2" "$width" "$height" "$vfov" "${eye[@]}" "${lookat[@]}" "${up[@]}" <<'EOF'
import json, math, sys
path, objects, w, h, vfov = sys.argv[1], json.loads(sys.argv[2]), *map(float, sys.argv[3:6])
eye, lookat, up = (list(map(float, sys.argv[k:k + 3])) for k in (6, 9, 12))
height = 2 * math.tan(math.radians(vfov) / 2)  # image plane at focal length 1
camera = {"type": "perspective", "eye": eye, "look": [l - e for l, e in zip(lookat, eye)],
          "up": up, "focal_length": 1, "height": height, "width": height * w / h,
          "resolution": [int(w), int(h)]}
with open(path, "w") as f:
    json.dump({"comment": "peer benchmark camera (benches/peers.sh)", "camera": camera,
               "objects": objects}, f, indent=1)
EOF
}

# Waits (up to WAIT_IDLE s) for other processes to be idle, as peer_bench.py does per peer,
# and writes the CPUs they used just before into FILE. Args: FILE.
wait_for_idle() {
    rm -f "$1"
    [[ $wait_idle == 0 ]] && return 0
    "$py" - "$peer_dir" "$wait_idle" "$1" <<'EOF'
import sys
sys.path.insert(0, sys.argv[1])
from peer_bench import wait_idle
busy = wait_idle(float(sys.argv[2]))
print("others using %.2f CPUs before raycast bench" % busy, file=sys.stderr)
open(sys.argv[3], "w").write("%.2f\n" % busy)
EOF
}

peer_bench() { # WORKLOAD
    "$py" "$peer_dir/peer_bench.py" "$out/torus.obj" --width "$width" --height "$height" \
        --eye "${eye[@]}" --lookat "${lookat[@]}" --up "${up[@]}" --vfov "$vfov" \
        --out "$out/peers/" --workloads "$1" --repeats "$runs" --wait-idle "$wait_idle" \
        ${peer_args[@]+"${peer_args[@]}"} | tee "$out/peers-$1.jsonl" >&2
}

raycast_bench() { # SCENE NAME
    wait_for_idle "$out/raycast-$2.idle"
    "$raycast" bench "$1" --json --runs "$runs" ${raycast_args[@]+"${raycast_args[@]}"} |
        tee "$out/raycast-$2.jsonl" >&2
}

write_scene "$out/torus.json" '[{"type": "soup", "obj": "torus.obj"}]'
say "== torus: raycast"
raycast_bench "$out/torus.json" torus
say "== torus: peers"
peer_bench mesh || say "warning: peer_bench.py failed on the mesh workload"
say "== torus: raycast again"
raycast_bench "$out/torus.json" torus-after

# peer_bench.py writes the spheres (centres and radii, seed 0) into OUT/spheres.json.
[[ -f $out/peers/spheres.json ]] || die "peer_bench.py wrote no $out/peers/spheres.json"
objects=$("$py" -c '
import json, sys
s = json.load(open(sys.argv[1]))
print(json.dumps([{"type": "sphere", "center": c, "radius": r}
                  for c, r in zip(s["centers"], s["radii"])]))' "$out/peers/spheres.json")
write_scene "$out/spheres.json" "$objects"
say "== spheres: raycast"
raycast_bench "$out/spheres.json" spheres
say "== spheres: peers"
peer_bench spheres || say "warning: peer_bench.py failed on the spheres workload"
say "== spheres: raycast again"
raycast_bench "$out/spheres.json" spheres-after

# --- the table -----------------------------------------------------------------------------
"$py" - "$out" <<'EOF' | tee "$out/table.md"
import json, os, statistics, sys

out = sys.argv[1]

def lines(name):
    path = os.path.join(out, name)
    if not os.path.exists(path):
        return []
    rows = []
    for line in open(path):
        try:
            rows.append(json.loads(line))
        except ValueError:
            pass  # not a JSON line
    return rows

def num(x, digits=3):
    if x is None:
        return "-"
    return "%.*g" % (digits, x)

def ratio(a, b):
    return "-" if not a or not b else "%.2f" % (a / b)

def geometric_mean(*xs):
    """Geometric mean of the values given (None where one is missing)."""
    return None if any(x is None for x in xs) else statistics.geometric_mean(xs)

def cpu():
    """The CPU's model and widest vector instructions: the peers' JIT and SIMD code use
    AVX-512 where it exists, llvmpipe 256-bit vectors (docs/performance.md), so only runs on
    CPUs of one kind compare."""
    try:
        info = open("/proc/cpuinfo").read().splitlines()
    except OSError:
        return "unknown CPU"
    model = next((l.split(":", 1)[1].strip() for l in info if l.startswith("model name")), "?")
    flags = next((l.split(":", 1)[1].split() for l in info if l.startswith("flags")), [])
    widest = "AVX-512" if "avx512f" in flags else "AVX2" if "avx2" in flags else "no AVX2"
    return "%s, %s" % (model, widest)

print("Mrays/s ratio = raycast / peer (above 1: raycast casts faster); build ratio = "
      "raycast / peer (below 1: raycast builds faster). raycast rows: Mrays/s from GPU "
      "timestamps (kernel only) and from wall time (dispatch + readback), measured before "
      "and again after the peers; ratios use each, and the geometric mean of the two "
      "measurements (this machine's speed drifts: far apart, they say the run was "
      "disturbed). others CPU: CPUs used by other processes, during the timed runs (peers) "
      "or just before (raycast); above ~0.1 the numbers are contaminated.")
for workload, peers_file in (("torus", "peers-mesh.jsonl"), ("spheres", "peers-spheres.jsonl")):
    ours = [r for r in lines("raycast-%s.jsonl" % workload) if "mode" in r]
    again = [r for r in lines("raycast-%s-after.jsonl" % workload) if "mode" in r]

    def others(when):
        # Other processes' CPU use: during the timed runs for peers, just before for raycast.
        idle = os.path.join(out, "raycast-%s%s.idle" % (workload, when))
        return open(idle).read().strip() + " before" if os.path.exists(idle) else "-"
    peers = [r for r in lines(peers_file) if "peer" in r]
    setup = next((r for r in lines(peers_file) if r.get("kind") == "setup"), {})
    if ours:
        r = ours[0]
        what = "%d triangles" % r["triangles"] if r["triangles"] else "%d spheres" % r["spheres"]
        print("\n### %s (%s, %dx%d = %d rays)\n" % (workload, what, *r["size"], r["rays"]))
        print("raycast on %s, %s; peers on %d threads; CPU %s\n"
              % (r["adapter"], r["driver"], setup.get("threads") or 0, cpu()))
    else:
        print("\n### %s: raycast bench gave no result\n" % workload)
    print("| engine | build s | trace s | Mrays/s | hit % | others CPU "
          "| Mrays/s ratio (GPU) | Mrays/s ratio (wall) | build ratio |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for when, rows, suffix in (("before peers", ours, ""), ("after peers", again, "-after")):
        for r in rows:
            name = "raycast %s %s%s, %s" % (r["mode"], r["accel"],
                                            " (bvh)" if r["accel"] == "auto" and r["bvh"] else "",
                                            when)
            print("| %s, GPU timestamps | %s | %s | %s | %.1f | %s | | | |"
                  % (name, num(r["build_s"]), num(r["trace_gpu_s"]), num(r["mrays_per_s"]),
                     100 * r["hit_fraction"], others(suffix)))
            print("| %s, wall | %s | %s | %s | %.1f | %s | | | |"
                  % (name, num(r["build_s"]), num(r["trace_s"]), num(r["mrays_per_s_wall"]),
                     100 * r["hit_fraction"], others(suffix)))
    # The first configuration, before and after the peers (before alone if the second failed).
    runs_of_first = [rows[0] for rows in (ours, again) if rows]
    us = {}
    if runs_of_first:
        gpu = all(r["mrays_from"] == "gpu_timestamps" for r in runs_of_first)
        us = {key: geometric_mean(*(r[key] for r in runs_of_first))
              for key in ("mrays_per_s", "mrays_per_s_wall", "build_s")}
        us["mrays_from"] = "gpu_timestamps" if gpu else "wall"
    for p in peers:
        name = "%s %s" % (p["peer"], p.get("version", ""))
        if "error" in p:
            print("| %s | error: %s | | | | | | | |" % (p["peer"], p["error"][:100]))
            continue
        gpu_mrays = us.get("mrays_per_s") if us.get("mrays_from") == "gpu_timestamps" else None
        print("| %s | %s | %s | %s | %.1f | %s | %s | %s | %s |"
              % (name, num(p["build_s"]), num(p["trace_s"]), num(p["mrays_per_s"]),
                 100 * p["hit_fraction"], num(p.get("others_cpu"), 2),
                 ratio(gpu_mrays, p["mrays_per_s"]),
                 ratio(us.get("mrays_per_s_wall"), p["mrays_per_s"]),
                 ratio(us.get("build_s"), p["build_s"])))
EOF
