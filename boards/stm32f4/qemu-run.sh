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
# (The run itself: boards/support/qemu-run.sh.)
set -euo pipefail
exec "$(dirname "${BASH_SOURCE[0]}")/../support/qemu-run.sh" -machine netduinoplus2 \
    -serial "${QEMU_USART1:-null}" -serial "${QEMU_USART2:-null}" "${!#}"
