#!/usr/bin/env bash
# One frame as a Slurm job array: scripts/split-render.sh --engine slurm.
#   scripts/slurm-render.sh -n N -f OUT.png -- RENDER ARGS...
exec "$(dirname "$0")/split-render.sh" --engine slurm "$@"
