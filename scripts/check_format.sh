#!/usr/bin/env bash
# Fails, naming the files, when a C++ file differs from the pinned .clang-format (clang-format 14).
# Fix with: clang-format -i $(git ls-files '*.h' '*.cc')
set -euo pipefail
cd "$(dirname "$0")/.."
bad=()
while IFS= read -r f; do
  clang-format --style=file "$f" | cmp -s - "$f" || bad+=("$f")
done < <(git ls-files '*.h' '*.cc')
if [ ${#bad[@]} -ne 0 ]; then
  echo "error: ${#bad[@]} file(s) differ from .clang-format: ${bad[*]}" >&2
  echo "fix with: clang-format -i \$(git ls-files '*.h' '*.cc')" >&2
  exit 1
fi
