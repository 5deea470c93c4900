#!/usr/bin/env bash
# Installs everything jrgen needs to build, test and benchmark, from Debian's
# packages (Debian bookworm; run as root).
set -euo pipefail
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends \
  build-essential cmake \
  libeigen3-dev liburdfdom-dev libtinyxml-dev libfmt-dev \
  libgtest-dev libbenchmark-dev >/dev/null
echo "jrgen: dependencies installed"
