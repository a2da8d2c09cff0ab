#!/usr/bin/env bash
# cdshear_bench --step-error solves one step twice from the same state and warm start: with the
# reference's own settings the tested solve is the reference's, bit for bit (every error exactly
# 0, --stress-error's too), and with the shear defaults it is not (a median impulse error above
# 0, --error-locality's shares within [0, 1], a stress error in some stripe); --reference-newton
# with --polish ends each sample's polish on a solution; the samples --dump-samples writes hold
# the reference's step (bench/admm_step.py finds its contact laws met to round-off from the dumped
# contacts, impulses and velocities), and bench/fb_newton_step.py's Newton iterations reach that
# step (to round-off in a few iterations, as a right generalized Jacobian does on these small
# young packings); bench/solution_set.py's split of their errors is an orthogonal one along which
# no grain moves, and bench/known_statuses.py's system of the reference's statuses solves to it
# (with --reuse, from a factorisation kept from the sample before too), and so does
# bench/adaptive_coarse.py's two-level preconditioner, and its six-level cycle, in one iteration
# where every coarse space is the whole space (with --bootstrap, kept to a sample's copy), and
# bench/schwarz_blocks.py's overlapping blocks where one block holds every unknown; so does
# bench/window_solve.py's window where it holds the whole cell.
# Usage: bench_step_error_test.sh CDSHEAR_BENCH WORKDIR
set -uo pipefail
bench=$1; work=$2
admm_step=$(cd "$(dirname "$0")/../bench" && pwd)/admm_step.py
fb_newton_step=$(cd "$(dirname "$0")/../bench" && pwd)/fb_newton_step.py
solution_set=$(cd "$(dirname "$0")/../bench" && pwd)/solution_set.py
known_statuses=$(cd "$(dirname "$0")/../bench" && pwd)/known_statuses.py
adaptive_coarse=$(cd "$(dirname "$0")/../bench" && pwd)/adaptive_coarse.py
schwarz_blocks=$(cd "$(dirname "$0")/../bench" && pwd)/schwarz_blocks.py
window_solve=$(cd "$(dirname "$0")/../bench" && pwd)/window_solve.py
rm -rf "$work"; mkdir -p "$work"; cd "$work"
fails=0
common=(--sizes 100 --no-static --steps 10 --warmup 20 --step-error 2 --step-error-spacing 5
        --error-locality --stress-error)
reference=(--alpha 1e-20 --converged-fraction 1 --max-sweeps 200000 --no-skip-dormant
           --slab-correction 0 --no-plain-finish --anderson 0 --relaxation 1
           --residual-tolerance 0)
if ! "$bench" "${common[@]}" "${reference[@]}" > same.csv 2> same.txt; then
  echo "FAIL: cdshear_bench with the reference's settings failed"; cat same.txt; exit 1
fi
if ! grep -qF "median impulse error 0.00e+00 (largest 0.00e+00), median top-wall error 0.00e+00 (largest 0.00e+00), median velocity error 0.00e+00 V (largest 0.00e+00 V)" same.txt; then
  echo "FAIL: the reference's settings did not give the reference's step"; cat same.txt
  fails=$((fails + 1))
fi
zero="stress error: bulk sigma_yy +0.0e+00, mu +0.0e+00 (mu "
if [[ $(grep -c "stress error:" same.txt) != 2 || $(grep "stress error:" same.txt | grep -F "$zero" |
      grep -cF "largest of bands of 4 d 0.0e+00, 0.0e+00; of 1 d 0.0e+00, 0.0e+00") != 2 ]]; then
  echo "FAIL: the reference's settings gave a stress error"; grep "stress error:" same.txt
  fails=$((fails + 1))
fi
if ! "$bench" "${common[@]}" --dump-samples dump > defaults.csv 2> defaults.txt; then
  echo "FAIL: cdshear_bench with the shear defaults failed"; cat defaults.txt; exit 1
fi
median=$(sed -n 's/.*median impulse error \([^ ]*\) .*/\1/p' defaults.txt)
if ! awk -v m="$median" 'BEGIN { exit !(m + 0 > 0) }'; then
  echo "FAIL: the shear defaults' step equals the reference's (median impulse error '$median')"
  fails=$((fails + 1))
fi
lines=$(grep -c "error locality:" defaults.txt)
bad=$(sed -n 's/.*status differences \([^ ]*\) of |e|^2, the 1% of contacts most off \([^;]*\);.*) \([^,]*\), off by.*/\1 \2 \3/p' \
        defaults.txt | awk '{ for (i = 1; i <= 3; ++i) if (!($i >= 0 && $i <= 1)) n++ } END { print n + 0 }')
if [[ "$lines" != 2 || "$bad" != 0 ]]; then
  echo "FAIL: expected 2 error-locality lines with shares in [0, 1], got $lines ($bad out of range)"
  grep "error locality:" defaults.txt; fails=$((fails + 1))
fi
stripes=$(sed -n 's/.*stress error: .* of 1 d \([^,]*\), \(.*\)$/\1 \2/p' defaults.txt |
            awk '$1 + $2 > 0 { n++ } END { print n + 0 }')
if [[ "$stripes" == 0 ]]; then
  echo "FAIL: the shear defaults' steps gave no stress error in any stripe"
  grep "stress error:" defaults.txt; fails=$((fails + 1))
fi
# The dumped samples: the reference's impulses and velocities meet the contact laws to round-off
# (W, the free term and the laws formed from the dump alone), the tested ones do not; twenty ADMM
# iterations from the tested impulses stay finite.
samples=(dump/shear_n*)
for k in 0 1; do
  if ! /usr/bin/python3 "$admm_step" "${samples[0]}/sample_$k" --rho 1 --iterations 20 > admm_$k.txt 2>&1; then
    echo "FAIL: admm_step.py on dumped sample $k failed"; cat admm_$k.txt; fails=$((fails + 1)); continue
  fi
  if ! awk '/candidates/ { t = $0; sub(/.*tested: error /, "", t); split(t, a, /[ ,;]+/);
                           r = $0; sub(/.*reference residual /, "", r);
                           ok = (a[3] + 0 > 1e-6 && r + 0 < 1e-8) }
            /from tested/ { f = ($0 !~ /nan|inf/) } END { exit !(ok && f) }' admm_$k.txt; then
    echo "FAIL: dumped sample $k: expected the reference's laws met and the tested ones not"
    cat admm_$k.txt; fails=$((fails + 1))
  fi
done
# Fischer-Burmeister Newton from the tested impulses: 5 iterations end at the reference's step
# (impulse error below 1e-8, natural-map residual below 1e-12) on both samples: the quadratic
# convergence of a right Jacobian (with a wrong one they converge linearly, still 1e-7 off).
for k in 0 1; do
  if ! /usr/bin/python3 "$fb_newton_step" "${samples[0]}/sample_$k" --iterations 5 \
      --starts tested > fb_$k.txt 2>&1; then
    echo "FAIL: fb_newton_step.py on dumped sample $k failed"; cat fb_$k.txt; fails=$((fails + 1))
    continue
  fi
  if ! awk '/from tested/ { n = split($0, a, /, /); split(a[n], b, /[: \/]+/);
                            ok = (b[2] + 0 < 1e-8 && b[3] + 0 < 1e-12) } END { exit !ok }' \
      fb_$k.txt; then
    echo "FAIL: dumped sample $k: Fischer-Burmeister Newton did not reach the reference's step"
    cat fb_$k.txt; fails=$((fails + 1))
  fi
done
# bench/solution_set.py splits each dumped sample's error into its part along the step's solution
# set and the rest: the part along the set moves no grain (|A B s*| at round-off against |A e|),
# the two parts are orthogonal (|e_det|^2 + |B s*|^2 = |e|^2 to the printed digits), and the set
# with both rows of every force-carrying contact free holds at least the share that the one with
# the reference's statuses holds.
if ! /usr/bin/python3 "$solution_set" "${samples[0]}" > set.txt 2>&1 ||
   ! /usr/bin/python3 "$solution_set" "${samples[0]}" --all-rows > set_all.txt 2>&1; then
  echo "FAIL: solution_set.py on the dumped samples failed"; cat set.txt set_all.txt
  fails=$((fails + 1))
else
  split='s/.*|e| \/ |R| \([^,]*\), undetermined share of |e| \([^,]*\), determinate |e_det| \/ |R| \([^;]*\);.*moves \([^ ]*\) of A e$/\1 \2 \3 \4/p'
  good=$(sed -n "$split" set.txt set_all.txt | awk '{ e = $1; x = $2; d = $3 }
           $4 + 0 < 1e-6 && (d * d + x * x * e * e - e * e) ^ 2 <= (2e-2 * e * e) ^ 2 { n++ }
           END { print n + 0 }')
  more=$(paste <(sed -n "$split" set.txt) <(sed -n "$split" set_all.txt) |
           awk '$6 + 1e-3 >= $2 { n++ } END { print n + 0 }')
  if [[ "$good" != 4 || "$more" != 2 ]]; then
    echo "FAIL: solution_set.py: expected 4 orthogonal splits along which no grain moves and 2" \
         "samples where all rows free hold as much, got $good and $more"
    cat set.txt set_all.txt; fails=$((fails + 1))
  fi
fi
# A known answer: one disk pressed between two fixed walls, both contacts sticking, its tested
# impulses the reference's plus equal normal impulses on both (a self-stress: the disk does not
# move): the whole error lies along the solution set, none of it is determinate.
mkdir -p squeezed
printf '# 10 0 1 0.004\n0 1 0 1 0.5 0 0 -0.5 0 0.5 1.1 0 1 0\n0 2 0 -1 0.5 0 0 0.5 0 0.5 1.1 0 1 0\n' \
  > squeezed/sample_0_contacts.txt
printf '# x y 1/m_x 1/m_y 1/I v_x v_y omega\n0 0.5 2 2 8 0 0 0\n0 0 0 0 0 0 0 0\n0 1 0 0 0 0 0 0\n' \
  > squeezed/sample_0_bodies.txt
if ! /usr/bin/python3 "$solution_set" squeezed > squeezed.txt 2>&1 ||
   ! grep -qF "undetermined share of |e| 1.000, determinate |e_det| / |R| 0.00e+00" squeezed.txt; then
  echo "FAIL: solution_set.py: a squeezed disk's self-stress was not found undetermined"
  cat squeezed.txt; fails=$((fails + 1))
fi
# bench/known_statuses.py: the linear system of the reference's statuses has the reference's step
# as its solution, and GMRES with each preconditioner reaches it from the tested impulses; with
# --reuse the first sample's kept factorisation is its own, every unknown shared, and the same
# iterations as its own incomplete LU.
if ! /usr/bin/python3 "$known_statuses" "${samples[0]}" --reuse > statuses.txt 2>&1; then
  echo "FAIL: known_statuses.py on the dumped samples failed"; cat statuses.txt; fails=$((fails + 1))
else
  exact=$(sed -n 's/.*exact solution \([^ ]*\) from the reference.*/\1/p' statuses.txt |
            awk '$1 + 0 < 1e-8 { n++ } END { print n + 0 }')
  reached=$(sed -n 's/.*; \([^ ]*\) after [0-9]*$/\1/p' statuses.txt |
              awk '$1 + 0 < 1e-6 { n++ } END { print n + 0 }')
  first=$(sed -n '1,/^sample_1/p' statuses.txt)
  shared=$(sed -n '1s/.*: \([0-9]*\) unknowns .* \([0-9]*\) shared with the kept.*/\1 \2/p' \
             statuses.txt | awk '$1 == $2 && $1 > 0 { print "all" }')
  own=$(grep -F "  ilu: " <<< "$first" | cut -d: -f2-)
  kept=$(grep -F "  ilu-kept: " <<< "$first" | cut -d: -f2-)
  if [[ "$exact" != 2 || "$reached" != 8 || "$shared" != all || -z "$own" || "$own" != "$kept" ]]
  then
    echo "FAIL: known_statuses.py: expected 2 exact solutions at the reference, 8 GMRES runs" \
         "reaching it and the first sample's kept factorisation its own, got $exact, $reached," \
         "'$shared', '$own' and '$kept'"; cat statuses.txt; fails=$((fails + 1))
  fi
fi
# bench/adaptive_coarse.py: with aggregates of one disk each (cells of 0.3 d; the test's disks
# are at least 0.8 d apart) and 16 unrelaxed random vectors, every aggregate's basis spans its
# unknowns, the coarse space is the whole space, and the two-level preconditioner is M's inverse:
# GMRES reaches the statuses' exact solution in one iteration on every sample. With six levels
# (none small enough to stop at) and 40 vectors, more than either sample's unknowns, the coarser
# levels' aggregates (cells of 0.6 to 9.6 d, merged 2 x 2 from level to level) span theirs too:
# every level is the whole space and the V-cycle is M's inverse (with 8 vectors the sixth level
# is not, and the check fails).
adaptive_check() {  # LEVELS VECTORS
  if ! /usr/bin/python3 "$adaptive_coarse" "${samples[0]}" --cell 0.3 --vectors "$2" --relax 0 \
       --levels "$1" --coarse-relax 0 --coarsest 0 > "adaptive$1.txt" 2>&1; then
    echo "FAIL: adaptive_coarse.py --levels $1 on the dumped samples failed"
    cat "adaptive$1.txt"; fails=$((fails + 1)); return
  fi
  local whole exact
  whole=$(sed -n "s/^sample_[0-9]*: .* levels' unknowns \([0-9, ]*\);.*/\1/p" "adaptive$1.txt" |
            awk -F', ' -v levels="$1" 'NF == levels && $1 > 0 {
                                         for (i = 2; i <= NF; i++) if ($i != $1) next; n++ }
                                       END { print n + 0 }')
  exact=$(sed -n "s/^  $1-level, own vectors .*; \([^ ]*\) after 1\$/\1/p" "adaptive$1.txt" |
            awk '$1 + 0 < 1e-8 { n++ } END { print n + 0 }')
  if [[ "$whole" != 2 || "$exact" != 2 ]]; then
    echo "FAIL: adaptive_coarse.py --levels $1: expected 2 samples with the whole space at each" \
         "of $1 levels and 2 one-iteration solves at the reference, got $whole and $exact"
    cat "adaptive$1.txt"; fails=$((fails + 1))
  fi
}
adaptive_check 2 16
adaptive_check 6 40
# --bootstrap on the first sample given twice: its 16 vectors, kept to the copy where every
# unknown is the same, span every one-disk aggregate there too, so the kept cycle is exact: its
# iterations on a random vector leave nothing (contraction 0), and the bootstrapped solve reaches
# the reference in one iteration.
mkdir -p twice
for file in "${samples[0]}"/sample_0_*; do
  cp "$file" twice/; cp "$file" "twice/$(basename "${file/sample_0_/sample_1_}")"
done
if ! /usr/bin/python3 "$adaptive_coarse" twice --cell 0.3 --vectors 16 --relax 0 --bootstrap 2 \
     > bootstrap.txt 2>&1; then
  echo "FAIL: adaptive_coarse.py --bootstrap on the first sample given twice failed"
  cat bootstrap.txt; fails=$((fails + 1))
elif ! grep -q "^sample_1: .*the kept cycle's contraction 0.000 per iteration$" bootstrap.txt ||
     ! awk '/^  2-level, bootstrapped vectors .* after 1$/ && $(NF - 2) + 0 < 1e-8 { n++ }
            END { exit n != 1 }' bootstrap.txt; then
  echo "FAIL: adaptive_coarse.py --bootstrap: expected the kept cycle exact on the sample's copy" \
       "(contraction 0) and its one-iteration solve at the reference"
  cat bootstrap.txt; fails=$((fails + 1))
fi
# bench/schwarz_blocks.py: where each connected piece of M's graph lies whole in one block (a
# cell wider than the test's cell, or cells of one disk grown by more rings than the graph is
# wide), the multiplicative sweep solves exactly, so GMRES reaches the statuses' exact solution in
# one iteration on both samples (with --coarse too, which checks only that the coarse correction
# composes with the sweep: the exact blocks override it); blocks of one disk without overlap are
# not exact.
schwarz_check() {  # EXACT(1|0) NAME OPTIONS...
  local exact=$1 name=$2; shift 2
  if ! /usr/bin/python3 "$schwarz_blocks" "${samples[0]}" "$@" > "schwarz_$name.txt" 2>&1; then
    echo "FAIL: schwarz_blocks.py $* on the dumped samples failed"
    cat "schwarz_$name.txt"; fails=$((fails + 1)); return
  fi
  local solved
  solved=$(awk '/^  blocks: .* after 1$/ && $(NF - 2) + 0 < 1e-8 { n++ } END { print n + 0 }' \
             "schwarz_$name.txt")
  if [[ ( $exact == 1 && $solved != 2 ) || ( $exact == 0 && $solved == 2 ) ]]; then
    echo "FAIL: schwarz_blocks.py $*: expected one-iteration solves at the reference on" \
         "$((exact * 2)) samples, got $solved"; cat "schwarz_$name.txt"; fails=$((fails + 1))
  fi
}
schwarz_check 1 whole --cell 1000 --overlap 0
schwarz_check 1 grown --cell 0.3 --overlap 1000
schwarz_check 1 coarse --cell 0.3 --overlap 1000 --coarse
schwarz_check 0 disks --cell 0.3 --overlap 0
# bench/window_solve.py: a window taller than the cell holds every contact, and its solve (the
# sweeps to convergence with nothing frozen) ends on the reference's step, which the reference's
# own impulses in it reach exactly; a window 1 d tall without a ring leaves some of the error.
window_check() {  # NAME PATTERN(awk, on the solved and oracle shares) OPTIONS...
  local name=$1 pattern=$2; shift 2
  if ! /usr/bin/python3 "$window_solve" "${samples[0]}" "$@" > "window_$name.txt" 2>&1; then
    echo "FAIL: window_solve.py $* on the dumped samples failed"
    cat "window_$name.txt"; fails=$((fails + 1)); return
  fi
  local met
  met=$(awk -F'; ' '/^sample_/ { split($3, s, " / "); if ('"$pattern"') n++ } END { print n + 0 }' \
          "window_$name.txt")
  if [[ $met != 2 ]]; then
    echo "FAIL: window_solve.py $*: expected ($pattern) on 2 samples, got $met"
    cat "window_$name.txt"; fails=$((fails + 1))
  fi
}
window_check whole 's[1] + 0 < 1e-6 && s[2] + 0 == 0' --height 1000
window_check thin 's[2] + 0 > 1e-3' --height 1 --overlap 0
# --reference-newton with --polish: the polish is 1 sweep and the active-set iterations from the
# tested impulses, and ends on a solution (natural-map residual and contact-law violation at
# round-off) on every sample.
if ! "$bench" "${common[@]}" --reference-newton 8 --polish > polish.csv 2> polish.txt; then
  echo "FAIL: cdshear_bench --reference-newton --polish failed"; cat polish.txt; exit 1
fi
solved=$(sed -n 's/.*polish: 1 sweeps, .*largest e dt \([^,]*\), natural-map residual \(.*\)$/\1 \2/p' \
           polish.txt | awk '$1 + 0 < 1e-12 && $2 + 0 < 1e-10 { n++ } END { print n + 0 }')
if [[ "$solved" != 2 ]]; then
  echo "FAIL: expected 2 polish lines of 1 sweep ending on a solution, got $solved"
  grep "polish:" polish.txt; fails=$((fails + 1))
fi
echo "bench_step_error_test: $fails failures"
exit $((fails > 0))
