#!/usr/bin/env bash
# The repository speaks of the product, not of how it was developed: no issue numbers, numbered
# stops or passes of work, or dated "since/until" notes in code, comments, docs, examples,
# scripts or messages. History goes to CHANGELOG.md and git. Prints each offending line and
# exits 1 if there is any; run by the test suite (no_process_words).
# Usage: scripts/check_process_words.sh [SOURCE_DIR]
set -euo pipefail
cd "${1:-$(dirname "$0")/..}"
ordinals='first|second|third|fourth|fifth|sixth|seventh|eighth|ninth|tenth|eleventh|twelfth'
ordinals+='|thirteenth|fourteenth|fifteenth|sixteenth|seventeenth|eighteenth|nineteenth'
ordinals+='|twentieth|twenty-[a-z]+|thirtieth'
pattern="\\bissues? ?#?[0-9]+\\b|\\b($ordinals) (stop|pass)\\b|\\bstops? [0-9]+\\b"
pattern+="|\\b(since|until|before|as of) 20[0-9]{2}-[0-9]{2}-[0-9]{2}\\b"
if git rev-parse --is-inside-work-tree > /dev/null 2>&1; then
  files=$(git ls-files --cached --others --exclude-standard)
else
  files=$(find . -type f -not -path './build*' -not -path './.git/*' | sed 's|^\./||')
fi
# CHANGELOG.md is the history; this script names the patterns; binary files and data are skipped.
files=$(printf '%s\n' "$files" | grep -v -E '^(CHANGELOG\.md|scripts/check_process_words\.sh)$' |
  grep -E '\.(cpp|hpp|h|py|sh|md|toml|txt|cmake|ipynb|json|in)$|^\.ci/|(^|/)CMakeLists\.txt$' |
  grep -v -E '^(campaigns/[^/]+/|docs/validation/runs/)' || true)
found=$(printf '%s\n' "$files" | tr '\n' '\0' | xargs -0 grep -H -n -i -E "$pattern" -- 2> /dev/null || true)
if [ -n "$found" ]; then
  printf '%s\n' "$found"
  echo "check_process_words: $(printf '%s\n' "$found" | wc -l) lines speak of the development" \
       "process (issue numbers, numbered stops or passes, dated since/until notes): say what the" \
       "product does instead, and put the history in CHANGELOG.md" >&2
  exit 1
fi
echo "check_process_words: none in $(printf '%s\n' "$files" | wc -l) files"
