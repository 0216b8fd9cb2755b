#!/usr/bin/env bash
# Builds the firmware for QEMU's netduinoplus2 (STM32F405, defmt over semihosting) into
# ../target/variants/ (the boards' variants), boots it with USART1 (the laser) and USART2 (the host link) on Unix
# sockets, and drives it with ../support/qemu_link_check.py: a stand-in scanner answers the
# bring-up, the boot Hello is decoded, SICK telegrams go through the pipeline, Shutdown ends the run.
# Exits non-zero if the check or QEMU (the firmware's exit code) fails.
#
#   ./qemu-check.sh [--no-build] [--telegrams N]
set -euo pipefail
cd "$(dirname "$0")"
source ../support/qemu-sockets.sh
# The ELF is read from boards/target, where the board crates build (.cargo/config.toml).
unset CARGO_TARGET_DIR

run_args qemu-check.sh "--telegrams" "$@"

features=(--no-default-features --features chip-f405,log-semihosting)
elf=../target/variants/thumbv7em-none-eabihf/release/stm32f4-board
if [[ $build -eq 1 ]]; then
    cargo build --release --target-dir ../target/variants "${features[@]}"
fi

qemu_start usart1 usart2 90 "$elf"
check_rc=0
python3 ../support/qemu_link_check.py --laser "$sockets/usart1.sock" --host "$sockets/usart2.sock" \
    "${check_args[@]}" || check_rc=$?
qemu_finish qemu-check.sh "link check" "$check_rc"
