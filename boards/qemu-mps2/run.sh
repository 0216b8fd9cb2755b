#!/usr/bin/env bash
# Builds the firmware, boots it in QEMU (mps2-an386) with UART0 and UART1 on Unix sockets,
# feeds UART0 and checks the echo on UART1 (uart_echo.py), decodes the defmt log with
# defmt-print, and exits with QEMU's exit code (the firmware's; or 1 if the echo was wrong).
#
#   ./run.sh                      the built-in echo payload
#   ./run.sh --payload FILE       send FILE to UART0 (it must contain a 0x04)
#   ./run.sh --out FILE           also save what came out of UART1
#   ./run.sh --no-build           use the ELF already built
#
# For an interactive session use `cargo run --release | defmt-print -e
# target/thumbv7em-none-eabihf/release/qemu-mps2` and connect to TCP 127.0.0.1:4440 (UART0)
# and 4441 (UART1).
set -euo pipefail
cd "$(dirname "$0")"
source ../support/qemu-sockets.sh

run_args run.sh "--payload|--out|--timeout" "$@"

elf=target/thumbv7em-none-eabihf/release/qemu-mps2
if [[ $build -eq 1 ]]; then
    cargo build --release
fi

qemu_start uart0 uart1 60 "$elf"
check_rc=0
python3 uart_echo.py --uart0 "$sockets/uart0.sock" --uart1 "$sockets/uart1.sock" \
    "${check_args[@]}" || check_rc=$?
qemu_finish run.sh "echo check" "$check_rc"
