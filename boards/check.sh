#!/usr/bin/env bash
# The board crates' checks, for developers and CI alike:
#   1. tools: the Cortex-M targets, llvm-tools (llvm-size), defmt-print, qemu-system-arm,
#      each installed only if missing;
#   2. the root memory.x is the QEMU board's;
#   3. format and lints (clippy, warnings denied) of the board crates;
#   4. release builds: qemu-mps2, stm32f4 (the NUCLEO-F446RE, and the STM32F405 build for
#      QEMU's netduinoplus2), microbit;
#   5. each firmware in QEMU: boot, self-check, and a small recording through the real
#      pipeline, Shutdown, exit code 0, bit-identical to the library in process:
#      - qemu-mps2 on mps2-an386 (`pyramid run --board qemu`: telegrams on UART0, the link on
#        UART1) against `--board host`, and the link checked by an independent
#        implementation of both formats (qemu-mps2/run.sh);
#      - stm32f4 on netduinoplus2 (`--board netduinoplus2`: a stand-in scanner answers the
#        bring-up on USART1, the link on USART2) against `--board host`, and the link checked
#        by an independent implementation of both formats (stm32f4/qemu-check.sh);
#      - microbit on microbit (telegrams and the link on its one UART) against the library's
#        co-processor of the same configuration (host/tests/run_microbit.rs);
#   6. the on-target tests (defmt-test) in QEMU, for thumbv7em-none-eabihf and
#      thumbv6m-none-eabi (both on the mps2-an386), and the thumbv6m ones on the microbit's
#      real Cortex-M0;
#   7. flash, static RAM and stack of each board.
# Any failure stops the script with a non-zero exit code.
#
#   boards/check.sh                  everything
#   boards/check.sh --no-lint        skip step 3
#   boards/check.sh --lint-only      steps 1 to 3 only (`cargo xtask test --lint` runs them
#                                    beside the host's test build, then the rest --no-lint)
#   boards/check.sh --runs-from DIR  step 5's three runs are not run again: their outputs are
#                                    read from DIR, where `cargo test --workspace` left them
#                                    with PYRAMID_QEMU_OUT=DIR (`cargo xtask test` does this)
set -euo pipefail
boards="$(cd "$(dirname "$0")" && pwd)"
root="$(dirname "$boards")"
qemu_dir="$boards/qemu-mps2"
stm32_dir="$boards/stm32f4"
microbit_dir="$boards/microbit"
# Every board crate builds into boards/target (its .cargo/config.toml); the STM32F4 firmware
# for QEMU's netduinoplus2 (STM32F405), other features of the same binary, into the variants'.
target_dir="$boards/target"
unset CARGO_TARGET_DIR
nd_features=(--no-default-features --features chip-f405,log-semihosting --target-dir "$target_dir/variants")

lint=1
lint_only=0
runs_from=""
while [[ $# -gt 0 ]]; do
    case "$1" in
        --no-lint) lint=0 ;;
        --lint-only) lint_only=1 ;;
        --runs-from)
            [[ $# -ge 2 ]] || { echo "check.sh: --runs-from needs a directory" >&2; exit 2; }
            runs_from="$2"
            shift
            ;;
        *) echo "check.sh: unknown argument $1" >&2; exit 2 ;;
    esac
    shift
done

start=$SECONDS
step() { printf '\n==> [%4ds] %s\n' "$((SECONDS - start))" "$*"; }
fail() { printf '\ncheck.sh: FAILED: %s\n' "$*" >&2; exit 1; }
trap 'rc=$?; if [[ $rc -ne 0 ]]; then printf "\ncheck.sh: FAILED (exit %d) after %ds\n" "$rc" "$((SECONDS - start))" >&2; fi' EXIT

step "tools"
rustup target add thumbv7em-none-eabihf thumbv6m-none-eabi
rustup component add rustfmt clippy llvm-tools
host=$(rustc -vV | sed -n 's/^host: //p')
llvm_size="$(rustc --print sysroot)/lib/rustlib/$host/bin/llvm-size"
[[ -x "$llvm_size" ]] || fail "llvm-size not found at $llvm_size"
if ! command -v defmt-print >/dev/null; then
    # Unoptimised: it decodes logs of a few kilobytes, and builds in about 40 s, not two minutes.
    cargo install --debug defmt-print --locked
fi
if ! command -v qemu-system-arm >/dev/null; then
    as_root=()
    [[ $(id -u) -ne 0 ]] && as_root=(sudo)
    "${as_root[@]}" apt-get update
    DEBIAN_FRONTEND=noninteractive "${as_root[@]}" apt-get install -y qemu-system-arm
fi
command -v python3 >/dev/null || fail "python3 is needed for the link checks"
defmt-print --version
qemu-system-arm --version | head -1

step "the root memory.x is the default board's (boards/qemu-mps2/memory-an386.x)"
cmp "$root/memory.x" "$qemu_dir/memory-an386.x" || fail "memory.x and boards/qemu-mps2/memory-an386.x differ"

if [[ $lint -eq 1 ]]; then
    # The three crates' lints start side by side, each into its log, shown in order once all
    # have ended (they share boards/target, where cargo runs one build at a time and shares
    # the check of the dependencies they have in common).
    step "format and lints: qemu-mps2 (thumbv7em and thumbv6m, firmware and tests, the paper's stairs firmware), stm32f4 (NUCLEO-F446RE and netduinoplus2 builds), microbit"
    lint_logs=$(mktemp -d)
    (cd "$qemu_dir" && cargo fmt --check \
        && cargo clippy --release --all-targets -- -D warnings \
        && cargo clippy --release --all-targets --target thumbv6m-none-eabi -- -D warnings \
        && cargo clippy --release --features paper-stairs --bin qemu-mps2-paper-stairs -- -D warnings) \
        > "$lint_logs/qemu-mps2" 2>&1 &
    qemu_lint=$!
    (cd "$stm32_dir" && cargo fmt --check \
        && cargo clippy --release -- -D warnings \
        && cargo clippy --release "${nd_features[@]}" -- -D warnings) \
        > "$lint_logs/stm32f4" 2>&1 &
    stm32_lint=$!
    (cd "$microbit_dir" && cargo fmt --check && cargo clippy --release -- -D warnings) \
        > "$lint_logs/microbit" 2>&1 &
    microbit_lint=$!
    lint_failed=()
    for pair in "qemu-mps2 $qemu_lint" "stm32f4 $stm32_lint" "microbit $microbit_lint"; do
        read -r board pid <<<"$pair"
        wait "$pid" || lint_failed+=("$board")
        echo "--- $board"
        cat "$lint_logs/$board"
    done
    rm -rf "$lint_logs"
    [[ ${#lint_failed[@]} -eq 0 ]] || fail "format or lints: ${lint_failed[*]}"
fi
if [[ $lint_only -eq 1 ]]; then
    [[ $lint -eq 1 ]] || fail "--lint-only and --no-lint leave nothing to do"
    step "done (format and lints only) in $((SECONDS - start)) s"
    exit 0
fi

step "build: qemu-mps2 (release)"
(cd "$qemu_dir" && cargo build --release)
step "build: stm32f4 (release; NUCLEO-F446RE and netduinoplus2)"
(cd "$stm32_dir" && cargo build --release)
(cd "$stm32_dir" && cargo build --release "${nd_features[@]}")
step "build: microbit (release)"
(cd "$microbit_dir" && cargo build --release)

# The host side of these runs (`pyramid`, the tests) is the build `cargo test --workspace`
# makes (`cargo xtask test` runs it first): `--workspace` keeps the features unified as there,
# so nothing is compiled again; the firmware is always the release build.
# board_run NAME FILTER WHAT PATTERN: one test of host/tests/NAME.rs, its outputs kept under
# $smoke and its log required to hold PATTERN; with --runs-from, the test passed already and
# its outputs are read from there.
board_run() {
    if [[ -n "$runs_from" ]]; then
        echo "from $smoke (the test passed in cargo test --workspace)"
        return
    fi
    local log="$smoke/$2.log"
    (cd "$root" && PYRAMID_QEMU_OUT="$smoke" cargo test --workspace --test "$1" "$2" -- --nocapture) \
        2>&1 | tee "$log" \
        || fail "the $3 run failed (exit codes: 101 panic, 102 HardFault, 124 timeout)"
    grep -q "$4" "$log" || fail "$3 did not match"
}
# firmware_stack ELF DEFMT LOG: the firmware's defmt log decoded into LOG (and shown), its
# clean shutdown checked; prints its stack high-water mark.
firmware_stack() {
    [[ -f "$2" ]] || fail "no firmware log at $2"
    defmt-print -e "$1" < "$2" > "$3" 2>&1 || true
    cat "$3" >&2
    grep -q "shutdown:" "$3" || fail "the firmware of $1 did not shut down cleanly"
    sed -n 's/.*stack: high-water \([0-9]*\) bytes.*/\1/p' "$3" | tail -1
}
if [[ -n "$runs_from" ]]; then
    smoke="$(cd "$runs_from" && pwd)"
    keep_smoke=1
else
    smoke=$(mktemp -d)
    keep_smoke=0
fi

step "QEMU firmware: self-check, a recording through the pipeline, exit code"
# The synthetic recording of host/tests/run_qemu.rs through `pyramid run --board qemu` and
# `--board host`: every cell must be identical, QEMU must exit with 0 after Shutdown.
board_run run_qemu qemu_matches_host_on_a_synthetic_recording "QEMU firmware" "identical"
run_log="$smoke/firmware.log"
qemu_stack=$(firmware_stack "$target_dir/thumbv7em-none-eabihf/release/qemu-mps2" \
    "$smoke/synthetic-qemu/qemu/firmware.defmt" "$run_log")
grep -q "self-check passed" "$run_log" || fail "no self-check in the firmware's log"
[[ -n "$qemu_stack" ]] || fail "the firmware did not report its stack"
step "QEMU firmware: the link against an independent implementation (qemu-mps2/run.sh)"
(cd "$qemu_dir" && ./run.sh --no-build) > "$smoke/qemu-mps2-run.log" 2>&1 \
    || { cat "$smoke/qemu-mps2-run.log"; fail "qemu-mps2/run.sh"; }

step "stm32f4 on QEMU's netduinoplus2: the synthetic recording, bit-identical to the host"
board_run run_qemu netduinoplus2_matches_host_on_a_synthetic_recording netduinoplus2 \
    "netduinoplus2: .* identical"
nd_stack=$(sed -n 's/.*"stack_bytes":\([0-9]*\).*/\1/p' \
    "$smoke/synthetic-netduinoplus2/netduinoplus2/summary.json" 2>/dev/null || true)
[[ -n "$nd_stack" ]] || fail "netduinoplus2: no stack high-water mark"
step "stm32f4 on QEMU's netduinoplus2: the link against an independent implementation"
(cd "$stm32_dir" && ./qemu-check.sh --no-build) || fail "stm32f4/qemu-check.sh"

step "microbit on QEMU's microbit: the synthetic recording, bit-identical to the library"
board_run run_microbit microbit_matches_the_host_on_a_synthetic_recording microbit \
    "microbit: .* on both"
mb_stack=$(firmware_stack "$target_dir/thumbv6m-none-eabi/release/microbit-board" \
    "$smoke/microbit-synthetic/firmware.defmt" "$smoke/microbit-firmware.log")
[[ -n "$mb_stack" ]] || fail "the microbit firmware did not report its stack"

passed=0
for target in thumbv7em-none-eabihf thumbv6m-none-eabi; do
    step "on-target tests: $target (QEMU mps2-an386)"
    runner_var="CARGO_TARGET_$(echo "$target" | tr 'a-z-' 'A-Z_')_RUNNER"
    test_log=$(mktemp)
    (cd "$qemu_dir" && env "$runner_var=$qemu_dir/qemu-run.sh" QEMU_TIMEOUT=120 \
        cargo test --release --target "$target") 2>&1 | tee "$test_log" \
        || fail "on-target tests failed for $target"
    binaries=$(grep -c "Running tests/" "$test_log" || true)
    ok=$(grep -c "all tests passed!" "$test_log" || true)
    [[ $binaries -gt 0 && $ok -eq $binaries ]] \
        || fail "$target: $ok of $binaries test binaries reported success"
    n=$(grep -Ec '^\([0-9]+/[0-9]+\) running' "$test_log" || true)
    [[ $n -gt 0 ]] || fail "$target: no test ran"
    echo "$target: $n tests in $binaries binaries passed"
    passed=$((passed + n))
    rm -f "$test_log"
done

step "on-target tests: thumbv6m-none-eabi on QEMU's microbit (a real Cortex-M0, 16 KiB)"
test_log=$(mktemp)
"$microbit_dir/run-mps2-tests.sh" 2>&1 | tee "$test_log" || fail "on-target tests failed on the microbit"
n=$(grep -Ec '^\([0-9]+/[0-9]+\) running' "$test_log" || true)
[[ $n -gt 0 ]] || fail "microbit: no test ran"
echo "microbit (Cortex-M0): $n tests passed"
passed=$((passed + n))
rm -f "$test_log"

step "sizes (default pyramid: 8 layers of 64 x 64 cells; microbit: 4 layers of 16 x 16)"
size_of() { # ELF -> "flash ram data"
    "$llvm_size" -A "$1" | awk '
        $1 == ".vector_table" || $1 == ".text" || $1 == ".rodata" { flash += $2 }
        $1 == ".data" { flash += $2; ram += $2; data += $2 }
        $1 == ".bss" || $1 == ".uninit" { ram += $2 }
        END { print flash, ram, data + 0 }'
}
read -r qemu_flash qemu_ram qemu_data < <(size_of "$target_dir/thumbv7em-none-eabihf/release/qemu-mps2")
read -r stm_flash stm_ram stm_data < <(size_of "$target_dir/thumbv7em-none-eabihf/release/stm32f4-board")
read -r nd_flash nd_ram nd_data < <(size_of "$target_dir/variants/thumbv7em-none-eabihf/release/stm32f4-board")
read -r mb_flash mb_ram mb_data < <(size_of "$target_dir/thumbv6m-none-eabi/release/microbit-board")
# The maps, the classifier and the queues start as all zero bits, in .bss. A type whose
# unconfigured value is not all zeros would move them to .data: copied from flash at boot,
# the image grown by the whole static RAM. Hold .data to a few small statics.
for pair in "qemu-mps2 $qemu_data" "stm32f4 $stm_data" "netduinoplus2 $nd_data" "microbit $mb_data"; do
    read -r board data <<<"$pair"
    [[ $data -le 1024 ]] || fail "$board: $data B of initialised statics (.data): a large static is no longer all zeros"
done
# The stack column: each firmware's high-water mark over the synthetic recording (the Reply to
# Shutdown); the NUCLEO build runs the netduinoplus2 build's code but for the clock and logging.
printf '%-34s %12s %16s %22s\n' board "flash (B)" "static RAM (B)" "stack high-water (B)"
printf '%-34s %12s %16s %22s\n' "qemu-mps2 (4M/4M)" "$qemu_flash" "$qemu_ram" "$qemu_stack"
printf '%-34s %12s %16s %22s\n' "stm32f4 NUCLEO-F446RE (512K/128K)" "$stm_flash" "$stm_ram" "on the board (RTT log)"
printf '%-34s %12s %16s %22s\n' "stm32f4 netduinoplus2 (1M/128K)" "$nd_flash" "$nd_ram" "$nd_stack"
printf '%-34s %12s %16s %22s\n' "microbit nRF51822 (256K/16K)" "$mb_flash" "$mb_ram" "$mb_stack"
[[ $stm_flash -le $((512 * 1024)) ]] || fail "stm32f4: the image exceeds the 512 KiB flash"
[[ $stm_ram -le $((128 * 1024 - 8 * 1024)) ]] || fail "stm32f4: under 8 KiB of RAM left for the stack"
[[ $nd_ram -le $((128 * 1024 - 8 * 1024)) ]] || fail "netduinoplus2: under 8 KiB of RAM left for the stack"
[[ $mb_flash -le $((256 * 1024)) ]] || fail "microbit: the image exceeds the 256 KiB flash"
# The painted stack cannot see past its region: keep 256 bytes never touched.
[[ $((mb_ram + mb_stack)) -le $((16 * 1024 - 256)) ]] \
    || fail "microbit: statics $mb_ram + stack $mb_stack B leave under 256 B of its 16 KiB"
[[ $keep_smoke -eq 1 ]] || rm -rf "$smoke"

step "done in $((SECONDS - start)) s"
echo "on-target: $passed passed, 0 failed"
