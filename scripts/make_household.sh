#!/usr/bin/env bash
# The household example of issue #15 (item 5, a microwave), end to end: scripts/make_own_category.sh microwave CACHE [WORK].
exec "$(dirname "$0")/make_own_category.sh" microwave "$@"
