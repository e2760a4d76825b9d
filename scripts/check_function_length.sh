#!/usr/bin/env bash
# Functions in core/, ui/ and app/ stay under 80 lines (main excepted),
# measured as Universal Ctags measures them (a function's first to last
# line). Prints each longer one and exits 1; exits 0 when none is.
#   bash scripts/check_function_length.sh [MAX_LINES]
set -euo pipefail
cd "$(dirname "$0")/.."
max=${1:-80}
ctags --output-format=json --fields=+neK --kinds-c++=f -R core ui app |
  python3 -c '
import json, sys
limit, long = int(sys.argv[1]), []
for line in sys.stdin:
    tag = json.loads(line)
    if "end" in tag and tag["name"] != "main" and tag["end"] - tag["line"] + 1 > limit:
        long.append("%s:%d %s: %d lines" % (tag["path"], tag["line"], tag["name"], tag["end"] - tag["line"] + 1))
print("\n".join(long) if long else "no function over %d lines" % limit)
sys.exit(1 if long else 0)
' "$max"
