#!/usr/bin/env bash
# Runs the on-target tests of boards/qemu-mps2/tests/ (defmt-test, built for
# thumbv6m-none-eabi) on QEMU's `microbit`: a real Cortex-M0 with 16 KiB of RAM, where CI runs
# the same ARMv6-M code on the mps2-an386's Cortex-M4.
#
# The test ELFs are those of the qemu-mps2 crate, unchanged but for one linker argument: the
# AN386 map puts the stack top at 0x2040_0000 (4 MiB of RAM); `--defsym=_stack_start=
# 0x20004000` moves it to the top of the nRF51822's 16 KiB (the code and statics already sit
# at 0x0 and 0x2000_0000 in both maps). `cargo rustc --test NAME` passes it to that test alone
# (cargo still builds the qemu-mps2 firmware for an integration test, without it: its 75 KiB
# of statics would not link with it). Built into boards/target with the other boards (the
# defsym is part of the tests' fingerprint: cargo builds them again, in about a second, when
# they were last built for the mps2-an386). Exits non-zero if any test binary fails.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
mps2="$here/../qemu-mps2"
export QEMU_TIMEOUT="${QEMU_TIMEOUT:-120}"

failed=0
for src in "$mps2"/tests/*.rs; do
    name=$(basename "$src" .rs)
    echo "==> $name (qemu-mps2/tests/$name.rs) on microbit"
    elf=$(cd "$mps2" && cargo rustc --release --target thumbv6m-none-eabi --test "$name" \
            --message-format=json-render-diagnostics \
            -- -C link-arg=--defsym=_stack_start=0x20004000 \
        | NAME="$name" python3 -c 'import json,os,sys
for line in sys.stdin:
    m = json.loads(line)
    if m.get("reason") == "compiler-artifact" and m.get("executable") \
            and m["target"]["name"] == os.environ["NAME"] and "test" in m["target"]["kind"]:
        print(m["executable"])' | tail -1)
    [[ -n "$elf" ]] || { echo "run-mps2-tests.sh: no test ELF for $name" >&2; exit 2; }
    "$here/qemu-run.sh" "$elf" || failed=$((failed + 1))
done
[[ $failed -eq 0 ]] || { echo "run-mps2-tests.sh: $failed test binaries failed" >&2; exit 1; }
