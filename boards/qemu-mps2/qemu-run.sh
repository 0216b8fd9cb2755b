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
# (The run itself: boards/support/qemu-run.sh.)
set -euo pipefail
exec "$(dirname "${BASH_SOURCE[0]}")/../support/qemu-run.sh" \
    -machine "${QEMU_MACHINE:-mps2-an386}" -cpu "${QEMU_CPU:-cortex-m4}" \
    -serial "${QEMU_UART0:-null}" -serial "${QEMU_UART1:-null}" "${!#}"
