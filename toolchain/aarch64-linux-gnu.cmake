# Cross build for aarch64-linux-gnu (Raspberry Pi 4/5 class); tests under qemu-aarch64.
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(OMNI4_TRIPLET aarch64-linux-gnu)
set(OMNI4_QEMU qemu-aarch64)
include(${CMAKE_CURRENT_LIST_DIR}/linux-cross.cmake)
