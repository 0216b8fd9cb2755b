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

build=1
helper_args=()
while [[ $# -gt 0 ]]; do
    case "$1" in
        --no-build) build=0 ;;
        --payload|--out|--timeout) helper_args+=("$1" "$2"); shift ;;
        *) echo "run.sh: unknown argument $1" >&2; exit 2 ;;
    esac
    shift
done

elf=target/thumbv7em-none-eabihf/release/qemu-mps2
if [[ $build -eq 1 ]]; then
    cargo build --release
fi

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
export QEMU_UART0="unix:$tmp/uart0.sock,server=on,wait=on"
export QEMU_UART1="unix:$tmp/uart1.sock,server=on,wait=on"
export QEMU_TIMEOUT="${QEMU_TIMEOUT:-60}"

./qemu-run.sh "$elf" 2> >(grep -v "QEMU waiting for connection" >&2) &
qemu_pid=$!

helper_rc=0
python3 uart_echo.py --uart0 "$tmp/uart0.sock" --uart1 "$tmp/uart1.sock" "${helper_args[@]}" \
    || helper_rc=$?
qemu_rc=0
wait "$qemu_pid" || qemu_rc=$?

echo "run.sh: QEMU exit code $qemu_rc, echo check exit code $helper_rc"
if [[ $qemu_rc -ne 0 ]]; then
    exit "$qemu_rc"
fi
exit "$helper_rc"
