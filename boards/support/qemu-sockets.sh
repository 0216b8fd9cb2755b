# Sourced by a board's run script that drives its firmware in QEMU through two serial ports on
# Unix sockets (boards/qemu-mps2/run.sh, boards/stm32f4/qemu-check.sh): the arguments they
# share, QEMU's start in the background with both sockets, and the exit codes at the end.
# Each script runs the checker (qemu_link_check.py) on the sockets between the two calls.

# run_args SCRIPT VALUE-OPTIONS ARGS...: reads the script's arguments. Sets `build` (1; 0 after
# --no-build) and `check_args` (every option of VALUE-OPTIONS, a list such as
# "--payload|--out", with its value, for the checker); any other argument ends the script with
# exit code 2.
run_args() {
    local script=$1 options=$2
    shift 2
    build=1
    check_args=()
    while [[ $# -gt 0 ]]; do
        if [[ $1 == --no-build ]]; then
            build=0
        elif [[ $# -ge 2 && "|$options|" == *"|$1|"* ]]; then
            check_args+=("$1" "$2")
            shift
        else
            echo "$script: unknown argument $1" >&2
            exit 2
        fi
        shift
    done
}

# qemu_start FIRST SECOND TIMEOUT ELF: starts ./qemu-run.sh ELF in the background (its pid in
# `qemu_pid`) with the serial ports FIRST and SECOND (e.g. uart0, uart1) on the Unix sockets
# $sockets/FIRST.sock and $sockets/SECOND.sock, where QEMU waits for a client before it starts
# the guest: `sockets` is a temporary folder, removed when the script exits; QEMU_FIRST and
# QEMU_SECOND (upper case) are the -serial specs qemu-run.sh reads. QEMU_TIMEOUT defaults to
# TIMEOUT seconds.
qemu_start() {
    local first=$1 second=$2 timeout=$3 elf=$4
    sockets=$(mktemp -d)
    trap 'rm -rf "$sockets"' EXIT
    export "QEMU_${first^^}=unix:$sockets/$first.sock,server=on,wait=on"
    export "QEMU_${second^^}=unix:$sockets/$second.sock,server=on,wait=on"
    export QEMU_TIMEOUT="${QEMU_TIMEOUT:-$timeout}"
    ./qemu-run.sh "$elf" 2> >(grep -v "QEMU waiting for connection" >&2) &
    qemu_pid=$!
}

# qemu_finish SCRIPT CHECK CHECK_RC: waits for QEMU, reports both exit codes (CHECK names the
# checker), and exits with QEMU's if it failed, else with the checker's.
qemu_finish() {
    local script=$1 check=$2 check_rc=$3
    local qemu_rc=0
    wait "$qemu_pid" || qemu_rc=$?
    echo "$script: QEMU exit code $qemu_rc, $check exit code $check_rc"
    if [[ $qemu_rc -ne 0 ]]; then
        exit "$qemu_rc"
    fi
    exit "$check_rc"
}
