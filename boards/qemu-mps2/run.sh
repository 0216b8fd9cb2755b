#!/usr/bin/env bash
# Builds the firmware, boots it in QEMU (mps2-an386) with UART0 (the laser) and UART1 (the host
# link) on Unix sockets, and drives it with ../support/qemu_link_check.py: a stand-in SICK
# answers the bring-up, the boot Hello is decoded, SICK telegrams go through the pipeline,
# Shutdown ends the run. Exits non-zero if the check or QEMU (the firmware's exit code) fails.
#
#   ./run.sh [--no-build] [--telegrams N]
#
# For an interactive session use `cargo run --release | defmt-print -e
# ../target/thumbv7em-none-eabihf/release/qemu-mps2` and connect to TCP 127.0.0.1:4440 (UART0)
# and 4441 (UART1); to map a recording through it, `pyramid run --board qemu` (docs/guide.md).
set -euo pipefail
cd "$(dirname "$0")"
source ../support/qemu-sockets.sh
# The ELF is read from boards/target, where the board crates build (.cargo/config.toml).
unset CARGO_TARGET_DIR

run_args run.sh "--telegrams" "$@"

elf=../target/thumbv7em-none-eabihf/release/qemu-mps2
if [[ $build -eq 1 ]]; then
    cargo build --release
fi

qemu_start uart0 uart1 90 "$elf"
check_rc=0
python3 ../support/qemu_link_check.py --laser "$sockets/uart0.sock" --host "$sockets/uart1.sock" \
    --clock-source 0 "${check_args[@]}" || check_rc=$?
qemu_finish run.sh "link check" "$check_rc"
