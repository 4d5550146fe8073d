# Helpers shared by the .ci/install-*.sh scripts. The sourcing script sets
# NAME (its name in messages) and log (where apt and npm output goes).

say() { echo "$NAME: $*" >&2; }
fail() { say "FAILED: $*"; exit 1; }

# Runs "$@" up to 4 times, 10 s apart: a mirror that is briefly unavailable
# should not fail the run.
retry() {
    local n
    for n in 1 2 3 4; do
        if "$@"; then return 0; fi
        say "attempt $n failed: $*"
        [ "$n" -lt 4 ] && sleep 10
    done
    return 1
}
