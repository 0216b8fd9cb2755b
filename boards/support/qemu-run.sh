#!/usr/bin/env bash
# What every board's `qemu-run.sh` does once it has named its machine: runs one firmware or
# test ELF in QEMU with semihosting and decodes its defmt output (on QEMU's stdout); exits
# with QEMU's exit code (the firmware's semihosting exit code: 0 when it ended well, 101 on a
# panic or failed test, 102 on a HardFault; 124 on a timeout).
#   support/qemu-run.sh QEMU-MACHINE-ARGS... ELF
# e.g. `-machine microbit -serial null path/to/elf`. Environment:
#   QEMU_TIMEOUT   seconds before the run is killed and fails (default 120)
#   DEFMT_RAW_OUT  if set, the raw defmt stream is also saved to this file
set -euo pipefail
elf="${!#}"
machine=("${@:1:$#-1}")
[[ -f "$elf" ]] || { echo "qemu-run.sh: no such ELF: $elf" >&2; exit 2; }
command -v defmt-print >/dev/null || { echo "qemu-run.sh: defmt-print missing (cargo install defmt-print)" >&2; exit 2; }

raw="${DEFMT_RAW_OUT:-}"
decode() {
    if [[ -n "$raw" ]]; then tee "$raw" | defmt-print -e "$elf"; else defmt-print -e "$elf"; fi
}

set +e
timeout --foreground -k 5 "${QEMU_TIMEOUT:-120}" \
    qemu-system-arm "${machine[@]}" -nographic -monitor none \
    -semihosting-config enable=on,target=native \
    -kernel "$elf" | decode
status=("${PIPESTATUS[@]}")
set -e
qemu_rc=${status[0]}
if [[ $qemu_rc -eq 124 || $qemu_rc -eq 137 ]]; then
    echo "qemu-run.sh: QEMU timed out after ${QEMU_TIMEOUT:-120} s" >&2
fi
if [[ ${status[1]} -ne 0 && $qemu_rc -eq 0 ]]; then
    echo "qemu-run.sh: defmt-print failed" >&2
    exit 3
fi
exit "$qemu_rc"
