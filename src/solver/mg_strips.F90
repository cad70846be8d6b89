! SPDX-License-Identifier: BSD-2-Clause
!> The rows that neighbouring strips of a distributed level of nuno's
!> multigrid exchange (module stencil_mg): its ghost rows of x before a
!> sweep or an interpolation, and the restriction's and Galerkin
!> product's partial sums of the neighbours' rows, sent to them and
!> added. A level's rows ys..ye on this rank, h padding rows each side;
!> below, above: the ranks of the neighbouring strips on comm
!> (MPI_PROC_NULL at the ends). Every rank of the level owns at least h
!> rows (mg_create keeps a level distributed only then). No allocation.
module mg_strips
  use mpi
  use kinds, only: rp
  use mg_kernels, only: mp
  implicit none
  private
  public :: strip_exchange, strip_sums_w, strip_sums_ac

contains

  !> The h ghost rows on each side of x(-h:nx-1+h, 3, ys-h:ye+h) from the
  !> neighbours' rows.
  subroutine strip_exchange(comm, below, above, x, ys, ye, h)
    integer, intent(in) :: comm, below, above, ys, ye, h
    real(mp), intent(inout), contiguous :: x(-h:, :, ys - h:)
    integer :: ierr, cnt
    cnt = size(x(:, :, ys:ys + h - 1))
    call MPI_Sendrecv(x(-h, 1, ys), cnt, MPI_REAL, below, 15, x(-h, 1, ye + 1), cnt, MPI_REAL, above, 15, &
                      comm, MPI_STATUS_IGNORE, ierr)
    call MPI_Sendrecv(x(-h, 1, ye - h + 1), cnt, MPI_REAL, above, 16, x(-h, 1, ys - h), cnt, MPI_REAL, below, 16, &
                      comm, MPI_STATUS_IGNORE, ierr)
  end subroutine strip_exchange

  !> rhs(0:nx-1, 3, ys:ye) = this rank's restriction sums w(-h:nx-1+h, 3,
  !> ys-h:ye+h) of its own rows plus the neighbours' sums of them; the
  !> padding rows of x (shaped as w) serve as receive buffers (the caller
  !> sets x afterwards).
  subroutine strip_sums_w(comm, below, above, nx, ys, ye, h, w, x, rhs)
    integer, intent(in) :: comm, below, above, nx, ys, ye, h
    real(mp), intent(in), contiguous :: w(-h:, :, ys - h:)
    real(mp), intent(inout), contiguous :: x(-h:, :, ys - h:)
    real(mp), intent(out), contiguous :: rhs(0:, :, ys:)
    integer :: ierr, cnt
    cnt = size(w(:, :, ys:ys + h - 1))
    x(:, :, ye + 1:ye + h) = 0.0_mp
    x(:, :, ys - h:ys - 1) = 0.0_mp
    call MPI_Sendrecv(w(-h, 1, ys - h), cnt, MPI_REAL, below, 13, x(-h, 1, ye + 1), cnt, MPI_REAL, above, 13, &
                      comm, MPI_STATUS_IGNORE, ierr)
    call MPI_Sendrecv(w(-h, 1, ye + 1), cnt, MPI_REAL, above, 14, x(-h, 1, ys - h), cnt, MPI_REAL, below, 14, &
                      comm, MPI_STATUS_IGNORE, ierr)
    rhs = w(0:nx - 1, :, ys:ye)
    rhs(:, :, ye - h + 1:ye) = rhs(:, :, ye - h + 1:ye) + x(0:nx - 1, :, ye + 1:ye + h)
    rhs(:, :, ys:ys + h - 1) = rhs(:, :, ys:ys + h - 1) + x(0:nx - 1, :, ys - h:ys - 1)
  end subroutine strip_sums_w

  !> The Galerkin sums ac(0:nx-1, 3, 3, -r:r, -r:r, ys-h:ye+h) of this
  !> rank's rows completed with the neighbours' sums of them (the rows
  !> below my strip go to the rank below; the rank above sends me its rows
  !> below its strip); acbuf(0:nx-1, 3, 3, -r:r, -r:r, h): receive buffer.
  subroutine strip_sums_ac(comm, below, above, r, ys, ye, h, ac, acbuf)
    integer, intent(in) :: comm, below, above, r, ys, ye, h
    real(rp), intent(inout), contiguous :: ac(0:, :, :, -r:, -r:, ys - h:)
    real(rp), intent(inout), contiguous :: acbuf(0:, :, :, -r:, -r:, :)
    integer :: ierr, cnt
    cnt = size(ac(:, :, :, :, :, ys:ys + h - 1))
    call MPI_Sendrecv(ac(0, 1, 1, -r, -r, ys - h), cnt, MPI_DOUBLE_PRECISION, below, 11, &
                      acbuf, cnt, MPI_DOUBLE_PRECISION, above, 11, comm, MPI_STATUS_IGNORE, ierr)
    if (above /= MPI_PROC_NULL) ac(:, :, :, :, :, ye - h + 1:ye) = ac(:, :, :, :, :, ye - h + 1:ye) + acbuf
    call MPI_Sendrecv(ac(0, 1, 1, -r, -r, ye + 1), cnt, MPI_DOUBLE_PRECISION, above, 12, &
                      acbuf, cnt, MPI_DOUBLE_PRECISION, below, 12, comm, MPI_STATUS_IGNORE, ierr)
    if (below /= MPI_PROC_NULL) ac(:, :, :, :, :, ys:ys + h - 1) = ac(:, :, :, :, :, ys:ys + h - 1) + acbuf
  end subroutine strip_sums_ac

end module mg_strips
