#!/usr/bin/env bash
# Runs one firmware or test ELF (thumbv6m-none-eabi) in QEMU's `microbit` (nRF51822, a real
# Cortex-M0 at 16 MHz, 256 KiB of flash, 16 KiB of RAM) and decodes its defmt output
# (semihosting, on QEMU's stdout); exits with QEMU's exit code (the firmware's semihosting
# exit code: 0 when it ended well, 101 on a panic or failed test, 102 on a HardFault; 124 on a
# timeout). Usable as a cargo runner:
#   CARGO_TARGET_THUMBV6M_NONE_EABI_RUNNER=$PWD/qemu-run.sh cargo run --release
#
# The machine has one UART (0x4000_2000), attached to the first -serial. Environment:
#   QEMU_UART      -serial spec of the UART (default: null)
#   QEMU_TIMEOUT   seconds before the run is killed and fails (default 120)
#   DEFMT_RAW_OUT  if set, the raw defmt stream is also saved to this file
# (The run itself: boards/support/qemu-run.sh.)
set -euo pipefail
exec "$(dirname "${BASH_SOURCE[0]}")/../support/qemu-run.sh" -machine microbit \
    -serial "${QEMU_UART:-null}" "${!#}"
