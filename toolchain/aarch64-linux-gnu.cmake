# Cross build for aarch64-linux-gnu (Debian cross compilers). Libraries come from the Debian packages
# that scripts/sysroot.sh unpacks into build/sysroot/aarch64-linux-gnu; tests run under qemu-aarch64.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
set(OMNI4_TRIPLET aarch64-linux-gnu)
set(OMNI4_SYSROOT ${CMAKE_CURRENT_LIST_DIR}/../build/sysroot/aarch64-linux-gnu)
set(CMAKE_FIND_ROOT_PATH ${OMNI4_SYSROOT} /usr/aarch64-linux-gnu)
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
set(CMAKE_CROSSCOMPILING_EMULATOR qemu-aarch64 -L /usr/aarch64-linux-gnu
    -E LD_LIBRARY_PATH=${OMNI4_SYSROOT}/usr/lib/aarch64-linux-gnu)
