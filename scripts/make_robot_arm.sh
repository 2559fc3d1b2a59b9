#!/usr/bin/env bash
# The robot arm of issue #15 (item 4), end to end: scripts/make_own_category.sh robot_arm CACHE [WORK].
exec "$(dirname "$0")/make_own_category.sh" robot_arm "$@"
