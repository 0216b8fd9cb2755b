#!/usr/bin/env bash
# Builds the firmware for QEMU's netduinoplus2 (STM32F405, defmt over semihosting) into
# target/netduinoplus2/, boots it with USART1 (the laser) and USART2 (the host link) on Unix
# sockets, and drives it with qemu_link_check.py: a stand-in scanner answers the bring-up,
# the boot Hello is decoded, SICK telegrams go through the pipeline, Shutdown ends the run.
# Exits non-zero if the check or QEMU (the firmware's exit code) fails.
#
#   ./qemu-check.sh [--no-build] [--telegrams N]
set -euo pipefail
cd "$(dirname "$0")"

build=1
check_args=()
while [[ $# -gt 0 ]]; do
    case "$1" in
        --no-build) build=0 ;;
        --telegrams) check_args+=("$1" "$2"); shift ;;
        *) echo "qemu-check.sh: unknown argument $1" >&2; exit 2 ;;
    esac
    shift
done

features=(--no-default-features --features chip-f405,log-semihosting)
elf=target/netduinoplus2/thumbv7em-none-eabihf/release/stm32f4-board
if [[ $build -eq 1 ]]; then
    cargo build --release --target-dir target/netduinoplus2 "${features[@]}"
fi

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
export QEMU_USART1="unix:$tmp/usart1.sock,server=on,wait=on"
export QEMU_USART2="unix:$tmp/usart2.sock,server=on,wait=on"
export QEMU_TIMEOUT="${QEMU_TIMEOUT:-90}"

./qemu-run.sh "$elf" 2> >(grep -v "QEMU waiting for connection" >&2) &
qemu_pid=$!

check_rc=0
python3 qemu_link_check.py --laser "$tmp/usart1.sock" --host "$tmp/usart2.sock" "${check_args[@]}" \
    || check_rc=$?
qemu_rc=0
wait "$qemu_pid" || qemu_rc=$?

echo "qemu-check.sh: QEMU exit code $qemu_rc, link check exit code $check_rc"
if [[ $qemu_rc -ne 0 ]]; then
    exit "$qemu_rc"
fi
exit "$check_rc"
