# Cross build for arm-linux-gnueabihf (Debian cross compilers). Libraries come from the Debian packages
# that scripts/sysroot.sh unpacks into build/sysroot/arm-linux-gnueabihf; tests run under qemu-arm.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR arm)
set(CMAKE_C_COMPILER arm-linux-gnueabihf-gcc)
set(CMAKE_CXX_COMPILER arm-linux-gnueabihf-g++)
set(OMNI4_TRIPLET arm-linux-gnueabihf)
set(OMNI4_SYSROOT ${CMAKE_CURRENT_LIST_DIR}/../build/sysroot/arm-linux-gnueabihf)
set(CMAKE_FIND_ROOT_PATH ${OMNI4_SYSROOT} /usr/arm-linux-gnueabihf)
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
set(CMAKE_CROSSCOMPILING_EMULATOR qemu-arm -L /usr/arm-linux-gnueabihf
    -E LD_LIBRARY_PATH=${OMNI4_SYSROOT}/usr/lib/arm-linux-gnueabihf)
