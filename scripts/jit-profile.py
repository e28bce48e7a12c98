#!/usr/bin/env python3
"""Where a kernel's time goes on lavapipe: runs a raycast command under `perf record` with
llvmpipe dumping the assembly of what it compiles (GALLIVM_DEBUG=asm, the shader cache off so
every kernel is compiled and dumped), finds where the compute kernel (`cs_co_variant`) was
loaded by matching the sampled addresses onto its instruction offsets, and prints the hottest
basic blocks; the whole annotated assembly goes to --out. Not part of CI (needs perf).

    scripts/jit-profile.py [--out annotated.s] [--top 25] -- target/release/raycast bench \\
        target/bench/torus.json --runs 3

Read a block's instructions in the annotated file to see which WGSL it is (box tests are dense
vsubps/vmulps/vminps, per-lane storage loads are a test, a bounds check and a scalar load per
lane). docs/experiments.md says what such profiles found.
"""
import argparse
import collections
import os
import re
import subprocess
import sys
import tempfile

KERNEL = "cs_co_variant:"


def kernel_instructions(asm_text):
    """(offset, instruction) of the last kernel in the dump (the one the command ran last)."""
    lines = asm_text.split("\n")
    starts = [i for i, line in enumerate(lines) if line == KERNEL]
    if not starts:
        sys.exit("jit-profile: no compute kernel in llvmpipe's dump (is the adapter lavapipe?)")
    out = []
    for line in lines[starts[-1] + 1:]:
        m = re.match(r"\s*([0-9a-f]+):\t(.*)", line)
        if m:
            out.append((int(m.group(1), 16), m.group(2)))
        elif line.endswith(":") and out:
            break
    return out


def sampled_addresses(perf_data):
    """Sample counts by address, of samples in JIT code (perf names it an anonymous map)."""
    script = subprocess.run(["perf", "script", "-i", perf_data, "-F", "ip,dso"],
                            capture_output=True, text=True, check=True).stdout
    counts = collections.Counter()
    for line in script.splitlines():
        parts = line.split()
        if len(parts) == 2 and ("perf-" in parts[1] or "JIT" in parts[1] or "anon" in parts[1]):
            counts[int(parts[0], 16)] += 1
    return counts


def kernel_base(offsets, counts):
    """The load address under which most samples fall on instruction boundaries."""
    best = (0, None)
    for ip, _ in counts.most_common(5):
        for offset in offsets:
            base = ip - offset
            hits = sum(c for a, c in counts.items() if a - base in offsets)
            best = max(best, (hits, base), key=lambda b: b[0])
    return best


def blocks(instructions):
    """Basic blocks as lists of indices, split after jumps and returns."""
    out, current = [], []
    for i, (_, text) in enumerate(instructions):
        current.append(i)
        if text.startswith("j") or text.startswith("ret"):
            out.append(current)
            current = []
    return out + ([current] if current else [])


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", default="jit-profile.s", help="annotated assembly (default %(default)s)")
    p.add_argument("--top", type=int, default=25, help="hottest blocks to print")
    p.add_argument("command", nargs=argparse.REMAINDER)
    a = p.parse_args()
    command = a.command[1:] if a.command[:1] == ["--"] else a.command
    if not command:
        p.error("give the command to profile after --")
    env = dict(os.environ, GALLIVM_DEBUG="asm", MESA_SHADER_CACHE_DISABLE="true")
    with tempfile.TemporaryDirectory() as tmp:
        perf_data = os.path.join(tmp, "perf.data")
        run = subprocess.run(["perf", "record", "-q", "-F", "4000", "-o", perf_data, "--"] + command,
                             env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        if run.returncode != 0:
            sys.exit(f"jit-profile: the command failed (exit {run.returncode})")
        instructions = kernel_instructions(run.stderr)
        counts = sampled_addresses(perf_data)
    offsets = {o for o, _ in instructions}
    matched, base = kernel_base(offsets, counts)
    if base is None or matched == 0:
        sys.exit("jit-profile: no samples fell in the kernel")
    per_offset = collections.Counter({a - base: c for a, c in counts.items() if a - base in offsets})
    total = sum(per_offset.values())
    share = [100.0 * per_offset[o] / total for o, _ in instructions]
    with open(a.out, "w") as f:
        for (o, text), s in zip(instructions, share):
            f.write(f"{s:6.2f} {o:6x} {text}\n")
    print(f"{matched} of {sum(counts.values())} JIT samples in the kernel "
          f"({len(instructions)} instructions); annotated assembly in {a.out}")
    for b in sorted(blocks(instructions), key=lambda b: -sum(share[i] for i in b))[:a.top]:
        first, last = instructions[b[0]][0], instructions[b[-1]][0]
        print(f"{sum(share[i] for i in b):6.2f}%  {first:x}..{last:x}  {len(b)} instructions")


if __name__ == "__main__":
    main()
