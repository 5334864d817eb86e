#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The VO on a Cortex-M7 model: unit tests and a short QVGA replay under qemu-system-arm -M mps2-an500
# (an MPS2 board with a Cortex-M7; newlib with semihosting for stdout and files).
#   tools/run-mcu.sh
# 1. builds the C core for Cortex-M7 (cmake/toolchains/cortex-m7.cmake, -Os) into $BUILD/m7 and for the host
#    (gcc, Release) into $BUILD/host;
# 2. links each unit test of MCU_TESTS (test/unit/test_*.c, cmocka replaced by test/mcu/shim/cmocka.h) and
#    the replay test/mcu/mcu_replay.c with test/mcu/startup_m7.c and test/mcu/mps2_an500.ld, and runs the
#    tests under qemu from the repository root (test_nn reads test/data/nn/ through semihosting);
# 3. with the shared data ($TVO_DATA_DIR, default ../shared/data): cuts the first 30 frames of
#    kitti/kitti07_160 to 320x240 (test/mcu/make_frames.py), replays them on the host and on the model with
#    the VO and the shipped step model in one static block of TVO_MCU_MEM bytes, and requires the two
#    runs' results (every field of every frame, the digest and the TUM trajectory) to be byte-identical;
#    prints the memory figures and the guest instructions per frame counted by qemu
#    (tools/qemu-insn-count.sh: in the tinyvo core's code, and in total), from a 30- and a 10-frame run,
#    and the 8 functions that run the most of them (tools/mcu-profile.sh).
#    Without the data the replay is skipped with a message.
# Environment: BUILD (default build/mcu), MCU_TESTS (default below), TVO_MCU_MEM (bytes, default 262144),
# PYTHON (default .venv/bin/python, needs numpy and opencv). Exit 1 on any failure.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
BUILD="${BUILD:-build/mcu}"
MCU_TESTS="${MCU_TESTS:-test_dmath test_se3 test_core test_camera test_pyramid test_nn test_corners test_lk test_affine test_relpose test_determinism}"
MEM="${TVO_MCU_MEM:-262144}"
PY="${PYTHON:-$ROOT/.venv/bin/python}"
DATA="${TVO_DATA_DIR:-$ROOT/../shared/data}"
. "$ROOT/tools/apt-lib.sh"
tvo_apt_ensure run-mcu qemu-system-arm gcc-arm-none-eabi libnewlib-arm-none-eabi cmake ninja-build || exit 1

TC=cmake/toolchains/cortex-m7.cmake
CPU=$(sed -n 's/^set(TVO_CPU_FLAGS "\(.*\)")/\1/p' "$TC")
QEMU=(qemu-system-arm -M mps2-an500 -display none -monitor none -serial none
      -semihosting-config enable=on,target=native)
# with the affine refinement built in (a Cortex-M build leaves it out by default), so that test_affine
# runs its portable kernel on the model; the QVGA replay's configuration does not use it
cmake -S . -B "$BUILD/m7" -G Ninja --toolchain "$TC" -DCMAKE_BUILD_TYPE=Release -DTVO_CORE_ONLY=ON \
      -DTVO_WITH_AFFINE=ON -DTVO_WERROR="${TVO_WERROR:-ON}" >/dev/null
cmake --build "$BUILD/m7" --target tinyvo >/dev/null
cmake -S . -B "$BUILD/host" -G Ninja -DCMAKE_BUILD_TYPE=Release -DTVO_CORE_ONLY=ON \
      -DTVO_WERROR="${TVO_WERROR:-ON}" >/dev/null
cmake --build "$BUILD/host" --target tinyvo >/dev/null
B="$ROOT/$BUILD"
CFLAGS=(-Os -std=c99 -ffp-contract=off -ffunction-sections -fdata-sections -Wall -Wextra -Werror)
# shellcheck disable=SC2086
arm-none-eabi-gcc $CPU "${CFLAGS[@]}" -c test/mcu/startup_m7.c -o "$B/startup_m7.o"
link() { # link OUT.elf OBJ...
  local out=$1
  shift
  # shellcheck disable=SC2086
  arm-none-eabi-gcc $CPU -nostartfiles --specs=rdimon.specs -T test/mcu/mps2_an500.ld -Wl,--gc-sections \
    -Wl,-Map="${out%.elf}.map" "$B/startup_m7.o" "$@" "$B/m7/lib/libtinyvo.a" -lm -o "$out"
}
status=0

echo "== Cortex-M7 (qemu-system-arm -M mps2-an500): unit tests"
for t in $MCU_TESTS; do
  # shellcheck disable=SC2086
  # TVO_WITH_LENS=0: what the core was built with (a Cortex-M build leaves the lens refinement out)
  arm-none-eabi-gcc $CPU -Os -std=c99 -ffp-contract=off -ffunction-sections -fdata-sections -DTVO_WITH_LENS=0 \
    -Itest/mcu/shim -Itest/common -Ilib/include -Ilib/src/internal -c "test/unit/$t.c" -o "$B/$t.o"
  objs=("$B/$t.o")
  if [ "$t" = test_corners ]; then # the second builds it compares the library's with (test/CMakeLists.txt)
    for second in fast_portable detect_all_cells; do
      # shellcheck disable=SC2086
      arm-none-eabi-gcc $CPU -Os -std=c99 -ffp-contract=off -ffunction-sections -fdata-sections -DTVO_WITH_LENS=0 \
        -Ilib/include -Ilib/src/internal -c "test/unit/$second.c" -o "$B/$second.o"
      objs+=("$B/$second.o")
    done
  fi
  link "$B/$t.elf" "${objs[@]}"
  start=$(date +%s)
  out=$(timeout 900 "${QEMU[@]}" -kernel "$B/$t.elf" 2>&1) || true
  passed=$(echo "$out" | sed -n 's/^\[  PASSED  \] \([0-9]*\) test.*/\1/p' | tail -1)
  if echo "$out" | grep -q '^\[  FAILED  \]' || [ -z "$passed" ]; then
    echo "$out" | grep -E 'error|FAILED|fault' | head -20
    echo "FAIL $t"; status=1
  else
    skipped=$(echo "$out" | sed -n 's/^\[  SKIPPED \] \([0-9]*\) test.*/\1/p' | tail -1)
    echo "ok   $t: $passed passed${skipped:+, $skipped skipped} ($(( $(date +%s) - start )) s)"
  fi
done

echo "== Cortex-M7: QVGA replay"
SEQ="$DATA/kitti/kitti07_160"
if [ ! -d "$SEQ/mav0" ]; then
  echo "skipped: no shared data at $SEQ (set TVO_DATA_DIR)"
  exit $status
fi
R="$B/replay"
mkdir -p "$R/m7" "$R/host"
"$PY" test/mcu/make_frames.py --euroc "$SEQ" --out "$R/frames30.bin" --frames 30 >/dev/null
"$PY" test/mcu/make_frames.py --euroc "$SEQ" --out "$R/frames10.bin" --frames 10 >/dev/null
MODEL=models/tinyvo_synth_euroc_logstep_relu.tvonn
gcc -O2 "${CFLAGS[@]:1}" -DTVO_MCU_MEM="$MEM" -Ilib/include test/mcu/mcu_replay.c "$B/host/lib/libtinyvo.a" -lm \
  -o "$R/host/mcu_replay"
# shellcheck disable=SC2086
arm-none-eabi-gcc $CPU "${CFLAGS[@]}" -DTVO_MCU_MEM="$MEM" -Ilib/include -c test/mcu/mcu_replay.c -o "$B/mcu_replay.o"
link "$R/m7/mcu_replay.elf" "$B/mcu_replay.o"
"$R/host/mcu_replay" "$R/frames30.bin" "$MODEL" "$R/host/traj.tum" "$R/host/results.txt" > "$R/host/out.txt"
declare -A insn
for n in 10 30; do
  cp "$R/frames$n.bin" "$R/m7/frames.bin"
  cp "$MODEL" "$R/m7/model.tvonn"
  (cd "$R/m7" && timeout 900 "$ROOT/tools/qemu-insn-count.sh" arm-none-eabi mcu_replay.map \
     __tvo_text_start:__tvo_text_end -- mcu_replay.elf > "out$n.txt" 2> "count$n.txt") || true
  insn[$n]=$(sed -n 's/^insncount: total \([0-9]*\) range \([0-9]*\)$/\1 \2/p' "$R/m7/count$n.txt")
done
cat "$R/m7/out30.txt"
host_digest=$(sed -n 's/^mcu: processed .* digest //p' "$R/host/out.txt")
m7_digest=$(sed -n 's/^mcu: processed .* digest //p' "$R/m7/out30.txt")
if grep -q '^mcu: PASS' "$R/m7/out30.txt" && grep -q '^mcu: PASS' "$R/host/out.txt" && [ -n "$m7_digest" ] &&
   [ "$host_digest" = "$m7_digest" ] && cmp -s "$R/host/results.txt" "$R/m7/results.txt" &&
   cmp -s "$R/host/traj.tum" "$R/m7/traj.tum"; then
  echo "ok   replay: Cortex-M7 results bit-identical to the host's (digest $m7_digest, results and trajectory byte-identical)"
else
  echo "FAIL replay: host digest '$host_digest', Cortex-M7 digest '$m7_digest'"
  diff "$R/host/results.txt" "$R/m7/results.txt" | head -4 || true
  status=1
fi
read -r t10 r10 <<<"${insn[10]:-0 0}"
read -r t30 r30 <<<"${insn[30]:-0 0}"
if [ "$t30" -gt 0 ] && [ "$t10" -gt 0 ]; then
  echo "guest instructions per frame (frames 11..30): tinyvo core $(( (r30 - r10) / 20 )), total $(( (t30 - t10) / 20 ))"
else
  echo "FAIL no instruction counts"; status=1
fi
BUILD="$BUILD" "$ROOT/tools/mcu-profile.sh" 8 || status=1
exit $status
