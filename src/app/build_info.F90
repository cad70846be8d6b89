! SPDX-License-Identifier: BSD-2-Clause
!> The version and git commit of this build, for `nuno --version` and the
!> start-up line. The commit comes from the include file that
!> cmake/git_commit.cmake rewrites at every build where it changed (the same
!> one output_results.F90 records in /run).
module build_info
  implicit none
  private
  public :: nuno_version, nuno_commit

#ifdef NUNO_VERSION
  character(len=*), parameter :: nuno_version = NUNO_VERSION
#else
  character(len=*), parameter :: nuno_version = 'unknown'
#endif
  include 'nuno_git_commit.inc'
  character(len=*), parameter :: nuno_commit = git_commit
end module build_info
