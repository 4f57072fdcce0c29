#!/usr/bin/env bash
# The grinding job split across two hosts: on this machine, two network namespaces joined
# by a veth pair (iproute2, needs root). The machine side (plant, kinematics, input
# shaper, force controller) runs in "hexA" = 10.200.0.1, the cell computer (planners,
# load predictors, the job client) in "hexB" = 10.200.0.2. DDS discovery: each side
# names the other in ROS_STATIC_PEERS (unicast discovery; no multicast needed).
#
#   sudo scripts/two_hosts.sh [hexctl demo options, e.g. --bead-length 120 --deadline 45]
#
# On two real computers: run the machine-side nodes on one and the rest on the other,
# with ROS_STATIC_PEERS=<the other's address> and the same ROS_DOMAIN_ID on both
# (docs/job.md, "More than one machine").
set -euo pipefail
cd "$(dirname "$0")/.."
HEXCTL="$PWD/.venv/bin/hexctl"
[ -x "$HEXCTL" ] || { echo "run 'make setup' first" >&2; exit 2; }
[ "$(id -u)" = 0 ] || { echo "needs root (ip netns)" >&2; exit 2; }

cleanup() { ip netns del hexA 2>/dev/null || true; ip netns del hexB 2>/dev/null || true; }
trap cleanup EXIT
cleanup
ip netns add hexA
ip netns add hexB
ip link add vethA type veth peer name vethB
ip link set vethA netns hexA
ip link set vethB netns hexB
ip -n hexA addr add 10.200.0.1/24 dev vethA
ip -n hexB addr add 10.200.0.2/24 dev vethB
for ns in hexA hexB; do ip -n $ns link set lo up; done
ip -n hexA link set vethA up
ip -n hexB link set vethB up

export ROS_DOMAIN_ID="${ROS_DOMAIN_ID:-42}" ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET
ROS_STATIC_PEERS=10.200.0.1 ip netns exec hexB "$HEXCTL" demo --output output/two_hosts \
    --machine-host "ip netns exec hexA" --machine-peers 10.200.0.2 "$@"
