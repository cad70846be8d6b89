! SPDX-License-Identifier: BSD-2-Clause
!> Module stencil_mg: the description of the hierarchy for -reduced_ksp_view
!> (per level its lattice, reach, blocks and bytes a node; the bytes a cycle
!> reads), apart from the cycles it describes.
submodule (stencil_mg) stencil_mg_describe
  implicit none

contains

  !> Lines that describe the hierarchy (for -reduced_ksp_view): per level
  !> its lattice, reach, stored blocks a node, bytes a node, and the bytes
  !> one cycle reads over all ranks (operators and vectors; the bandwidth
  !> bound of docs/performance.md). Collective.
  module subroutine mg_describe(mg, text, n)
    type(stencil_mg_t), intent(in) :: mg
    character(len=*), intent(out) :: text(:)
    integer, intent(out) :: n
    integer :: l, ierr, nact
    integer(kind=8) :: nodes8
    real(rp) :: per_node, sweep, cycle_bytes, mp_bytes
    character(len=32) :: on
    mp_bytes = real(storage_size(1.0_mp) / 8, rp)
    n = 1
    write(text(1), '(a, i0, a, a, a, i0, a)') 'levels ', mg%nlev, ', ', trim(cycle_name()), ', ', mg%nu, &
      ' symmetric Gauss-Seidel sweep(s) a smoothing, single precision'
    if (mg%seam .and. mg%nranks > 1) then
      n = n + 1
      text(n) = 'seam sweeps: each smoothing then sweeps the first rows of each strip above another forward once more ' &
                //'(the faces'' barrier blocks across strips)'
    end if
    cycle_bytes = 0.0_rp
    do l = 1, mg%nlev
      associate (a => mg%lev(l)%a)
        nodes8 = int(a%nx, 8) * int(a%ye - a%ys + 1, 8)
        if (.not. mg%lev(l)%replicated) call MPI_Allreduce(MPI_IN_PLACE, nodes8, 1, MPI_INTEGER8, MPI_SUM, mg%comm, ierr)
        ! operator: blocks of 9, the row sums and the inverted diagonal
        per_node = 9.0_rp * mp_bytes * real(a%nb + 2, rp)
        ! a symmetric smoothing: each sweep reads the operator (not the row
        ! sums), the right-hand side and x, and writes x; the backward sweep
        ! not the blocks to the rows below, but their sums the forward sweep
        ! kept (written and read: 3 values a node each)
        sweep = 2.0_rp * (9.0_rp * mp_bytes * real(a%nb + 1, rp) + 9.0_rp * mp_bytes) &
                - 9.0_rp * mp_bytes * real(count(a%odj < 0), rp) + 6.0_rp * mp_bytes
        ! paired (no bending): nor does the forward sweep, which takes them
        ! from the row below's blocks back up, read a row before
        if (a%paired) sweep = sweep - 9.0_rp * mp_bytes * real(count(a%odj < 0), rp)
        if (l < mg%nlev) then
          if (mg%cycle_type == CYCLE_KASKADE) then
            cycle_bytes = cycle_bytes + real(nodes8, rp) * mg%nu * sweep
          else
            ! 2 nu smoothings and a residual (operator, row sums, x, rhs,
            ! res), on each visit: once a cycle, or 2^(l-1) times in a W-cycle
            cycle_bytes = cycle_bytes + real(nodes8, rp) * real(mg%gamma, rp)**(l - 1) &
                          * (2.0_rp * mg%nu * sweep + per_node + 9.0_rp * mp_bytes)
          end if
        end if
        ! the ranks that hold rows of it, where gathered on fewer
        call MPI_Allreduce(merge(1, 0, a%ye >= a%ys), nact, 1, MPI_INTEGER, MPI_SUM, mg%comm, ierr)
        on = ''
        if (gather_on(mg%lev(l)%gat)) write(on, '(a, i0, a)') ' (gathered on ', nact, ' ranks)'
        n = n + 1
        write(text(n), '(a, i0, a, i0, a, i0, a, i0, a, i0, a, f0.0, a, a, a, a, a)') 'level ', l, ': ', a%nx, ' x ', a%ny, &
          ', reach ', a%r, ', ', a%nb, ' blocks a node, ', per_node, ' B a node', trim(on), &
          trim(merge(' (coarsest: banded LU on every rank)', '                                    ', l == mg%nlev)), &
          trim(merge(' (rediscretised)', '                ', l > 1 .and. mg%rediscretize)), trim(transfers(mg%lev(l)))
      end associate
    end do
    n = n + 1
    write(text(n), '(a, f0.1, a)') 'one cycle reads about ', cycle_bytes / 1.0e6_rp, ' MB over all ranks (levels above the coarsest)'
  contains
    !> The cycle, for the first line.
    function cycle_name() result(t)
      character(len=16) :: t
      select case (mg%cycle_type)
      case (CYCLE_KASKADE)
        t = 'kaskade cycle'
      case (CYCLE_W)
        t = 'W-cycle'
      case default
        t = 'V-cycle'
      end select
    end function cycle_name
    !> The transfers from the next coarser level, for the level's line.
    function transfers(lv) result(t)
      type(mg_level_t), intent(in) :: lv
      character(len=64) :: t
      t = ''
      if (lv%tx%nf == 0) return
      if (lv%cubic) then
        t = '; transfers from below cubic'
      else if (lv%cubic_up .and. mg%rediscretize) then
        t = '; restriction bilinear, interpolation cubic'
      else if (lv%cubic_up) then
        t = '; transfers from below bilinear, the correction cubic'
      else
        t = '; transfers from below bilinear'
      end if
    end function transfers
  end subroutine mg_describe

end submodule stencil_mg_describe
