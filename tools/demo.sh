#!/usr/bin/env bash
# The main job on the built-in simulated exoskeleton. Grows with the system; prints only what it
# measured.
set -euo pipefail
cd "$(dirname "$0")/.."
build/bin/pof version
