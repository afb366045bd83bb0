# Cross build for arm-linux-gnueabihf (older Pi / BeagleBone class); tests under qemu-arm.
set(CMAKE_SYSTEM_PROCESSOR arm)
set(OMNI4_TRIPLET arm-linux-gnueabihf)
set(OMNI4_QEMU qemu-arm)
include(${CMAKE_CURRENT_LIST_DIR}/linux-cross.cmake)
