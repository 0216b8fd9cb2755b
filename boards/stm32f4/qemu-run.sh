#!/usr/bin/env bash
# Runs one firmware ELF (built with `--no-default-features --features chip-f405,log-semihosting`)
# in QEMU's netduinoplus2 (an STM32F405, Cortex-M4F at a fixed 168 MHz) and decodes its defmt
# output (semihosting, on QEMU's stdout); exits with QEMU's exit code (the firmware's
# semihosting exit code: 0 after Shutdown, 101 on a panic, 102 on a HardFault; 124 on a
# timeout). Usable as a cargo runner:
#   CARGO_TARGET_THUMBV7EM_NONE_EABIHF_RUNNER=$PWD/qemu-run.sh \
#       cargo run --release --no-default-features --features chip-f405,log-semihosting
#
# The USARTs: QEMU attaches its -serial options in order to USART1, USART2, USART3, UART4,
# UART5, USART6, UART7 (hw/arm/stm32f405_soc.c), so the first is the laser's and the second
# the host link's. Environment:
#   QEMU_USART1    -serial spec of USART1, the laser (default: null)
#   QEMU_USART2    -serial spec of USART2, the host link (default: null)
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
    qemu-system-arm -machine netduinoplus2 -nographic -monitor none \
    -semihosting-config enable=on,target=native \
    -serial "${QEMU_USART1:-null}" -serial "${QEMU_USART2:-null}" \
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
