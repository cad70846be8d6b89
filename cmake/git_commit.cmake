# SPDX-License-Identifier: BSD-2-Clause
# Writes OUT, a Fortran include line with the commit recorded in every
# output file (/run git_commit): `git describe --always --dirty` of SRC, or
# 'unknown' outside a git checkout. Run at every build (target
# nuno_git_commit), so that a build after a new commit or an edit records
# what was built, not what was configured; OUT is rewritten only when the
# commit changed, so only the files that include it (src/output/output.F90,
# src/app/build_info.F90) are recompiled, and only then.
#   cmake -DSRC=<source dir> -DOUT=<file> -P cmake/git_commit.cmake
execute_process(COMMAND git describe --always --dirty
                WORKING_DIRECTORY "${SRC}"
                OUTPUT_VARIABLE commit OUTPUT_STRIP_TRAILING_WHITESPACE
                RESULT_VARIABLE result ERROR_QUIET)
if(NOT result EQUAL 0 OR NOT commit MATCHES "^[0-9A-Za-z._-]+$")
  set(commit "unknown")
endif()
file(WRITE "${OUT}.tmp" "    character(len=*), parameter :: git_commit = '${commit}'\n")
execute_process(COMMAND "${CMAKE_COMMAND}" -E copy_if_different "${OUT}.tmp" "${OUT}")
file(REMOVE "${OUT}.tmp")
