#!/usr/bin/env bash
# Installs everything jrgen needs to build, test and benchmark, from Debian's
# packages (Debian bookworm; run as root).  The solver report (docs/report.md)
# adds LAPACKE, OpenBLAS, SuiteSparse (UMFPACK), MuJoCo, gnuplot and Python.
set -euo pipefail
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends \
  build-essential cmake \
  libeigen3-dev liburdfdom-dev libtinyxml-dev libfmt-dev \
  libgtest-dev libbenchmark-dev \
  liblapacke-dev libopenblas-dev libsuitesparse-dev libmujoco-dev gnuplot-nox python3 >/dev/null
echo "jrgen: dependencies installed"
