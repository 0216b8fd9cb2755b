#!/usr/bin/env bash
# Builds the firmware, boots it in QEMU's `microbit` with the UART on a Unix socket, and drives
# it with qemu_uart_check.py: an echo, then SICK telegrams through the pipeline and the
# firmware's summary line. Exits non-zero if the check or QEMU (the firmware's exit code) fails.
#
#   ./qemu-check.sh [--no-build]
set -euo pipefail
cd "$(dirname "$0")"

build=1
for arg in "$@"; do
    case "$arg" in
        --no-build) build=0 ;;
        *) echo "qemu-check.sh: unknown argument $arg" >&2; exit 2 ;;
    esac
done

elf=target/thumbv6m-none-eabi/release/microbit-board
if [[ $build -eq 1 ]]; then
    cargo build --release
fi

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
export QEMU_UART="unix:$tmp/uart.sock,server=on,wait=on"
export QEMU_TIMEOUT="${QEMU_TIMEOUT:-120}"

./qemu-run.sh "$elf" 2> >(grep -v "QEMU waiting for connection" >&2) &
qemu_pid=$!

check_rc=0
python3 qemu_uart_check.py --uart "$tmp/uart.sock" || check_rc=$?
qemu_rc=0
wait "$qemu_pid" || qemu_rc=$?

echo "qemu-check.sh: QEMU exit code $qemu_rc, UART check exit code $check_rc"
if [[ $qemu_rc -ne 0 ]]; then
    exit "$qemu_rc"
fi
exit "$check_rc"
