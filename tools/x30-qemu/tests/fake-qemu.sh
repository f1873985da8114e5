#!/bin/sh
# A stand-in for qemu-system-arm in x30-qemu's tests (passed with --qemu). It prints its pid
# and arguments, "boots" (prints `led link on`), then echoes each line it gets on standard
# input as `uart MILLISECONDS LINE`, and acts on a few lines the way firmware might:
#   boom        prints `panic: boom` on standard error and exits 101 (semihosting exit)
#   hang-panic  prints `panic: stuck` and keeps running
#   exit N      exits with status N
#   stderr TEXT prints TEXT on standard error
# At the end of its input it keeps running, as QEMU does, until it is killed.
echo "fake-qemu pid $$"
echo "fake-qemu args $*"
boot=0.2
for arg in "$@"; do
    case "$arg" in
        boot=*) boot="${arg#boot=}" ;;
    esac
done
sleep "$boot"
echo "led link on"
while IFS= read -r line; do
    echo "uart $(date +%s%3N) $line"
    case "$line" in
        boom) echo "panic: boom" >&2; exit 101 ;;
        hang-panic) echo "panic: stuck" ;;
        "exit "*) exit "${line#exit }" ;;
        "stderr "*) echo "${line#stderr }" >&2 ;;
    esac
done
exec sleep 1000
