# Shared by the tests/cli/test_*.sh scripts (sourced, not a test itself): a scratch
# directory removed on exit, and the two checks every script uses.
TMP=$(mktemp -d)
# The trap keeps the script's exit status (a missing test function must not pass).
trap 'status=$?; rm -rf "$TMP"; exit $status' EXIT

fail() { echo "FAILED: $*" >&2; exit 1; }

# expect_status CODE COMMAND...: runs the command, stdout/stderr to $TMP/out, $TMP/err.
expect_status() {
  want=$1; shift
  "$@" >"$TMP/out" 2>"$TMP/err"
  got=$?
  [ "$got" -eq "$want" ] || { cat "$TMP/err" >&2; fail "$* exited $got, expected $want"; }
}
