#!/usr/bin/env bash
# Budgets of the lidar drivers (issue 25): instructions per packet and per
# point of each protocol's parser, alone and with the 720-beam revolution
# assembler, and the RAM of each type, on the Cortex-M4F (QEMU mps2-an386)
# and the Cortex-M0 (QEMU microbit). They are rows of the firmware budgets
# (tools/budgets/src/lidar.rs): `bash tools/budgets.sh` writes them into
# budgets/budgets.json and budgets/TABLE.md and `--check` holds them to
# 10 %; this prints them only, measured afresh (a quick look):
#
#   bash tools/lidar_budgets.sh      # = bash tools/budgets.sh --only lidar
set -euo pipefail
exec bash "$(dirname "$0")/budgets.sh" --only lidar "$@"
