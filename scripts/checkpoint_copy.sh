# Shared by scripts/solver_check.sh, scripts/paired_check.sh and bench/thread_scaling.sh (sourced,
# not run): the binary, the checks of a run folder with a checkpoint, its copy into a folder, and
# the checkpoint's time.

# The cdshear binary to use: $CDSHEAR, else the repository's build; exits 2 if it is not built.
checkpoint_cdshear() {
  local repo
  repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
  local cdshear=${CDSHEAR:-$repo/build/cdshear}
  [[ -x "$cdshear" ]] || { echo "error: $cdshear: not built (scripts/setup.sh)" >&2; exit 2; }
  echo "$cdshear"
}

# Exits 2 unless RUN is a run folder with a checkpoint.
require_checkpoint_run() {
  local f
  for f in case.toml checkpoint.cbor run.h5; do
    [[ -f "$1/$f" ]] || { echo "error: $1/$f: missing (not a run folder with a checkpoint)" >&2; exit 2; }
  done
}

# Copies RUN's checkpoint files into the existing folder DIR.
copy_checkpoint() {
  cp "$1/case.toml" "$1/checkpoint.cbor" "$1/run.h5" "$2/"
}

# Prints the time of the checkpoint copied into DIR, read by CDSHEAR: a resume asked to stop
# before it says it and does nothing (a finished run says how far it went instead). Exits 2 if
# it cannot be read, naming NAME (default DIR).
checkpoint_time() {
  local cdshear=$1 dir=$2 name=${3:-$2} time
  time=$("$cdshear" run --resume "$dir" --no-analyze --stop-at 1e-300 2>&1 |
         sed -n -e "s/.*not later than the run's time \([0-9.e+-]*\).*/\1/p" \
                -e "s/.*the run already reached t = \([0-9.e+-]*\) .*/\1/p" | head -1 || true)
  [[ -n "$time" ]] || { echo "error: $name: could not read the checkpoint's time" >&2; exit 2; }
  echo "$time"
}
