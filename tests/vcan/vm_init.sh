#!/bin/sh
# /init of the CAN test VM: CAN modules, vcan0, loopback multicast for LCM, then the tests.
export PATH=/bin:/sbin:/usr/bin:/usr/sbin:/omni4
mount -t proc proc /proc
mount -t sysfs sys /sys
mount -t devtmpfs dev /dev 2>/dev/null
mkdir -p /tmp && mount -t tmpfs tmp /tmp
for m in can can-raw can-dev vcan; do insmod /modules/$m.ko || echo "VCAN: insmod $m failed"; done
ip link set lo up
ip link set lo multicast on
ip route add 224.0.0.0/4 dev lo
# vcan hands every frame to the kernel's receive backlog (1000 frames by default): a starved VM
# overflows it and frames vanish after send() succeeded. Room for seconds of the bus.
echo 100000 > /proc/sys/net/core/netdev_max_backlog
ip link add dev vcan0 type vcan
ip link set vcan0 up
sh /omni4/vcan_tests.sh
poweroff -f
