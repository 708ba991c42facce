#!/bin/sh
# Makes LCM's UDP multicast (udpm://239.255.76.67:7667?ttl=0) work on a host whose only usable
# interface is loopback: enables MULTICAST on `lo` and routes 239.0.0.0/8 through it.
# Idempotent. Needs root; without root it prints the commands to run.
#
# Not needed where a default route exists (multicast with ttl=0 then goes out "through" that
# interface and is looped back locally without leaving the host; see docs/lcm.md), but it makes
# LCM independent of the network: a robot with its cable unplugged, a CI container without
# network.
set -eu

commands=""
if ! ip link show lo | grep -q MULTICAST; then
  commands="ip link set lo multicast on"
fi
if ! ip route show 239.0.0.0/8 | grep -q "dev lo"; then
  commands="${commands:+$commands
}ip route add 239.0.0.0/8 dev lo"
fi
if [ -z "$commands" ]; then
  echo "setup-lcm-loopback: lo already has MULTICAST and a 239.0.0.0/8 route"
  exit 0
fi
if [ "$(id -u)" -ne 0 ]; then
  echo "setup-lcm-loopback: not root; run:"
  echo "$commands" | sed 's/^/  sudo /'
  exit 1
fi
echo "$commands" | while read -r cmd; do
  echo "setup-lcm-loopback: $cmd"
  $cmd
done
