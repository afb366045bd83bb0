# Shared part of the ARM Linux toolchain files: the including file sets OMNI4_TRIPLET and
# OMNI4_QEMU. Debian cross compilers; libraries from the Debian packages that
# scripts/sysroot.sh unpacks into build/sysroot/TRIPLET; tests run under qemu-user.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_C_COMPILER ${OMNI4_TRIPLET}-gcc)
set(CMAKE_CXX_COMPILER ${OMNI4_TRIPLET}-g++)
set(OMNI4_SYSROOT ${CMAKE_CURRENT_LIST_DIR}/../build/sysroot/${OMNI4_TRIPLET})
set(CMAKE_FIND_ROOT_PATH ${OMNI4_SYSROOT} /usr/${OMNI4_TRIPLET})
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
set(CMAKE_CROSSCOMPILING_EMULATOR ${OMNI4_QEMU} -L /usr/${OMNI4_TRIPLET}
    -E LD_LIBRARY_PATH=${OMNI4_SYSROOT}/usr/lib/${OMNI4_TRIPLET})
