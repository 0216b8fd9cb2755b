#!/usr/bin/env bash
# Runs one firmware or test ELF in QEMU and decodes its defmt output; exits with QEMU's exit
# code (the firmware's semihosting exit code, 101 on a panic or failed test, 102 on a
# HardFault). Usable as a cargo runner:
#   CARGO_TARGET_THUMBV7EM_NONE_EABIHF_RUNNER=$PWD/qemu-run.sh cargo test --release
#
# The command line is the one of .cargo/config.toml's runner, plus decoding. Environment:
#   QEMU_MACHINE   mps2-an386 (default; Cortex-M4F, runs ARMv7E-M and ARMv6-M code alike)
#   QEMU_CPU       cortex-m4 (default)
#   QEMU_UART0     QEMU -serial spec of UART0 (default: null)
#   QEMU_UART1     QEMU -serial spec of UART1 (default: null)
#   QEMU_TIMEOUT   seconds before the run is killed and fails (default 120)
#   DEFMT_RAW_OUT  if set, the raw defmt stream is also saved to this file
set -euo pipefail
elf="${!#}"
[[ -f "$elf" ]] || { echo "qemu-run.sh: no such ELF: $elf" >&2; exit 2; }
command -v defmt-print >/dev/null || { echo "qemu-run.sh: defmt-print missing (cargo install defmt-print)" >&2; exit 2; }

raw="${DEFMT_RAW_OUT:-}"
decode() {
    if [[ -n "$raw" ]]; then tee "$raw" | defmt-print -e "$elf"; else defmt-print -e "$elf"; fi
}

set +e
timeout --foreground -k 5 "${QEMU_TIMEOUT:-120}" \
    qemu-system-arm -machine "${QEMU_MACHINE:-mps2-an386}" -cpu "${QEMU_CPU:-cortex-m4}" \
    -nographic -monitor none \
    -semihosting-config enable=on,target=native \
    -serial "${QEMU_UART0:-null}" -serial "${QEMU_UART1:-null}" \
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
