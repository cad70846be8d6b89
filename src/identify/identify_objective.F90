! SPDX-License-Identifier: BSD-2-Clause
!> The objective of an identification or a control (docs/identification.md):
!> the observation or target it compares with, the time windows between
!> the times it is evaluated at, and its terms in the forward run and in
!> the adjoint:
!>   J(theta) = sum_k w_k sum_nodes mask_n (|x_n(t_k) - xobs_n,k|^2
!>              + velocity_weight |v_n(t_k) - vobs_n,k|^2)
!>              + tikhonov sum_i (theta_i - theta_i,initial)^2
!> (the Tikhonov term is added by the caller, which knows theta).
module identify_objective
#include "petsc/finclude/petscsys.h"
  use petscsys
  use mpi
  use hdf5
  use kinds, only: rp
  use lattice, only: lattice_t
  use constraints, only: constraint_set_t, constraint_events
  implicit none
  private
  public :: ident_obs_t, obs_read, obs_windows, obs_residuals, obs_adjoint_terms

  !> The observation or target (owned rows only), the windows and the
  !> residuals of the last forward run; written only by this module.
  type :: ident_obs_t
    real(rp) :: vweight = 0                       !< weight of the velocity term [time^2]
    integer :: nt = 0                             !< observed times used (t > 0)
    real(rp), allocatable :: tobs(:), wt(:)       !< (nt) times [time], weights [1]
    real(rp), allocatable :: xobs(:, :, :, :)     !< (3, 0:nx-1, ys:ye, nt) observed positions [length]
    real(rp), allocatable :: vobs(:, :, :, :)     !< as xobs, velocities [length/time] (vweight > 0 only)
    real(rp), allocatable :: mask(:, :)           !< (0:nx-1, ys:ye) node weights (markers) [1]
    real(rp), allocatable :: res(:, :, :, :)      !< x - xobs of the last forward run, as xobs
    real(rp), allocatable :: resv(:, :, :, :)     !< v - vobs of the last forward run (vweight > 0 only)
    real(rp) :: nobs = 0                          !< scalar observations with weight > 0 (all ranks)
    ! time windows: [wa, wb], observation index at wb (0: none)
    integer :: nw = 0
    real(rp), allocatable :: wa(:), wb(:)
    integer, allocatable :: wobs(:)
  end type ident_obs_t

contains

  !> Windows: every observed time, keyframe and release time up to the last
  !> observation; and the residual arrays.
  subroutine obs_windows(o, cs)
    type(ident_obs_t), intent(inout) :: o
    type(constraint_set_t), intent(in) :: cs
    real(rp), allocatable :: ev(:), stops(:)
    real(rp) :: eps, tmax
    integer :: k, w

    tmax = o%tobs(o%nt)
    eps = 1.0e-12_rp * max(1.0_rp, tmax)
    ev = constraint_events(cs, tmax)
    stops = [o%tobs, pack(ev, ev < tmax - eps)]
    call sort_unique(stops, eps)
    o%nw = size(stops)
    allocate(o%wa(o%nw), o%wb(o%nw), o%wobs(o%nw))
    o%wb = stops
    o%wa(1) = 0.0_rp
    o%wa(2:) = stops(1:o%nw - 1)
    o%wobs = 0
    do w = 1, o%nw
      do k = 1, o%nt
        if (abs(o%tobs(k) - o%wb(w)) <= eps) o%wobs(w) = k
      end do
    end do
    allocate(o%res, mold=o%xobs)
    o%res = 0.0_rp
    if (o%vweight > 0.0_rp) then
      allocate(o%resv, mold=o%xobs)
      o%resv = 0.0_rp
    end if
  end subroutine obs_windows

  !> Forward run at observed time k: the residuals of the state u (this
  !> rank's rows, (0:5, 0:nx-1, ys:ye)) and their weighted squares added to
  !> floc, this rank's part of the data term of J.
  subroutine obs_residuals(o, k, lat, u, floc)
    type(ident_obs_t), intent(inout) :: o
    integer, intent(in) :: k
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: u(0:, 0:, lat%ys:)
    real(rp), intent(inout) :: floc
    integer :: i, j
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        o%res(:, i, j, k) = u(0:2, i, j) - o%xobs(:, i, j, k)
        floc = floc + o%wt(k) * o%mask(i, j) * sum(o%res(:, i, j, k)**2)
        if (o%vweight > 0.0_rp) then
          o%resv(:, i, j, k) = u(3:5, i, j) - o%vobs(:, i, j, k)
          floc = floc + o%wt(k) * o%mask(i, j) * o%vweight * sum(o%resv(:, i, j, k)**2)
        end if
      end do
    end do
  end subroutine obs_residuals

  !> Adjoint at observed time k: dJ_k/dU added to lambda (this rank's rows,
  !> as u of obs_residuals).
  subroutine obs_adjoint_terms(o, k, lat, la)
    type(ident_obs_t), intent(in) :: o
    integer, intent(in) :: k
    type(lattice_t), intent(in) :: lat
    real(rp), intent(inout) :: la(0:, 0:, lat%ys:)
    integer :: i, j
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        la(0:2, i, j) = la(0:2, i, j) + 2.0_rp * o%wt(k) * o%mask(i, j) * o%res(:, i, j, k)
        if (o%vweight > 0.0_rp) la(3:5, i, j) = la(3:5, i, j) + &
          2.0_rp * o%wt(k) * o%mask(i, j) * o%vweight * o%resv(:, i, j, k)
      end do
    end do
  end subroutine obs_adjoint_terms

  !> Sort ascending and drop values within eps of the previous one.
  subroutine sort_unique(a, eps)
    real(rp), allocatable, intent(inout) :: a(:)
    real(rp), intent(in) :: eps
    real(rp), allocatable :: b(:)
    real(rp) :: x
    integer :: i, j
    do i = 2, size(a)
      x = a(i)
      j = i - 1
      do while (j >= 1)
        if (a(j) <= x) exit
        a(j + 1) = a(j)
        j = j - 1
      end do
      a(j + 1) = x
    end do
    allocate(b(0))
    do i = 1, size(a)
      if (size(b) > 0) then
        if (a(i) <= b(size(b)) + eps) cycle
      end if
      b = [b, a(i)]
    end do
    a = b
  end subroutine sort_unique

  !> The observed motion: /time [nt] and /position [nt][ny][nx][3] (the
  !> layout of nuno's own output, model.md section 9), optional /mask
  !> [ny][nx] (node weights: 1 at an observed marker, 0 elsewhere) and
  !> /weight [nt] (per time), and /velocity [nt][ny][nx][3] where the
  !> objective weighs velocities (&control velocity_weight; absent: zero,
  !> the cloth at rest). Times <= 0 are left out (the initial positions do
  !> not depend on the parameters). Every rank reads its own rows; the
  !> checks are the same on every rank and the error flag is agreed.
  subroutine obs_read(o, lat, comm, vweight, path, group, key, ierr, errmsg)
    type(ident_obs_t), intent(inout) :: o
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: comm
    real(rp), intent(in) :: vweight           !< weight of the velocity term [time^2] (0: none)
    character(*), intent(in) :: path
    character(*), intent(in) :: group, key    !< the namelist key that names the file, for messages
    PetscErrorCode, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    integer(hid_t) :: file, dset, space, mspace
    integer(hsize_t) :: dims(4), maxdims(4), start(4), cnt(4)
    integer :: h, hopen, ndims, nx, ny, ys, nyl, ntall, k, n, e, mpierr
    real(rp), allocatable :: tall(:), wall(:), pall(:, :, :, :), vall(:, :, :, :), m2(:, :)
    logical :: exists, have_mask, have_weight
    character(len=:), allocatable :: where

    nx = lat%nx
    ny = lat%ny
    ys = lat%ys
    nyl = lat%ye - ys + 1
    o%vweight = vweight
    where = '&'//group//': '//key//" '"//path//"'"
    hopen = 0
    e = 0
    ntall = 0          ! sizes the /weight buffer even when /time was never read
    errmsg = ''
    file = -1
    call h5open_f(h)
    inquire(file=path, exist=exists)
    if (.not. exists) then
      e = 1
      errmsg = 'input: '//where//': no such file'
    end if
    if (e == 0) then
      ! HDF5's own error printing stays off: the line below says it (a
      ! file that is not HDF5 made a 33-line stack before it). The open's
      ! code is kept apart from the other calls' (h).
      call h5eset_auto_f(0, h)
      call h5fopen_f(path, H5F_ACC_RDONLY_F, file, hopen)
      h = hopen
      if (h < 0) then
        e = 1
        errmsg = 'input: '//where//': not an HDF5 file (or not readable)'
      end if
    end if
    ! /time
    if (e == 0) call open_dset('/time', 1, .true.)
    if (e == 0) then
      ntall = int(dims(1))
      allocate(tall(ntall))
      call h5dread_f(dset, H5T_NATIVE_DOUBLE, tall, dims(1:1), h)
      if (h < 0) call bad('cannot read /time')
      call h5dclose_f(dset, h)
    end if
    ! /position, this rank's rows; /velocity (optional) as /position, when
    ! the objective has a velocity term (control's velocity_weight)
    if (e == 0) call read_states('/position', pall, .true.)
    if (e == 0) then
      allocate(vall(3, 0:nx - 1, ys:ys + nyl - 1, ntall))
      vall = 0.0_rp
      if (o%vweight > 0.0_rp) call read_states('/velocity', vall, .false.)
    end if
    ! optional /mask and /weight
    allocate(m2(0:nx - 1, 0:ny - 1))
    m2 = 1.0_rp
    have_mask = .false.
    if (e == 0) then
      call h5lexists_f(file, '/mask', have_mask, h)
      if (have_mask) then
        call open_dset('/mask', 2, .true.)
        if (e == 0 .and. (dims(1) /= nx .or. dims(2) /= ny)) then
          write(errmsg, '(a,i0,a,i0,a)') 'input: '//where//': /mask must be [ny][nx] = [', ny, '][', nx, ']'
          e = 1
        end if
        if (e == 0) then
          call h5dread_f(dset, H5T_NATIVE_DOUBLE, m2, dims(1:2), h)
          if (h < 0) call bad('cannot read /mask')
          call h5dclose_f(dset, h)
        end if
      end if
    end if
    allocate(wall(max(ntall, 0)))
    wall = 1.0_rp
    if (e == 0) then
      call h5lexists_f(file, '/weight', have_weight, h)
      if (have_weight) then
        call open_dset('/weight', 1, .true.)
        if (e == 0 .and. dims(1) /= ntall) then
          write(errmsg, '(a,i0,a)') 'input: '//where//': /weight must be [nt] = [', ntall, '] like /time'
          e = 1
        end if
        if (e == 0) then
          call h5dread_f(dset, H5T_NATIVE_DOUBLE, wall, dims(1:1), h)
          if (h < 0) call bad('cannot read /weight')
          call h5dclose_f(dset, h)
        end if
      end if
    end if
    if (file >= 0) call h5fclose_f(file, h)
    if (e == 0) then
      if (any(m2 /= m2) .or. any(m2 < 0.0_rp) .or. any(wall /= wall) .or. any(wall < 0.0_rp)) then
        e = 1
        errmsg = 'input: '//where//': /mask and /weight must be finite and >= 0'
      else if (any(tall(2:) <= tall(:ntall - 1))) then
        e = 1
        errmsg = 'input: '//where//': /time must increase'
      else if (count_pos(tall) == 0) then
        e = 1
        errmsg = 'input: '//where//': no observed time > 0'
      else if (any(pall /= pall) .or. any(vall /= vall)) then
        e = 1
        errmsg = 'input: '//where//': /position or /velocity holds NaN'
      end if
    end if
    ! One decision for all ranks.
    call MPI_Allreduce(MPI_IN_PLACE, e, 1, MPI_INTEGER, MPI_MAX, comm, mpierr)
    if (e /= 0) then
      ierr = 1
      if (len_trim(errmsg) == 0) errmsg = 'input: '//where//': could not be read on some rank'
      return
    end if
    ierr = 0
    n = count_pos(tall)
    o%nt = n
    allocate(o%tobs(n), o%wt(n), o%xobs(3, 0:nx - 1, ys:ys + nyl - 1, n))
    if (o%vweight > 0.0_rp) allocate(o%vobs, mold=o%xobs)
    n = 0
    do k = 1, ntall
      if (tall(k) <= 0.0_rp) cycle
      n = n + 1
      o%tobs(n) = tall(k)
      o%wt(n) = wall(k)
      o%xobs(:, :, :, n) = pall(:, :, :, k)
      if (o%vweight > 0.0_rp) o%vobs(:, :, :, n) = vall(:, :, :, k)
    end do
    allocate(o%mask(0:nx - 1, ys:ys + nyl - 1))
    o%mask = m2(:, ys:ys + nyl - 1)
    o%nobs = 3.0_rp * real(count(m2 > 0.0_rp), rp) * real(count(o%wt > 0.0_rp), rp)
  contains
    integer function count_pos(t)
      real(rp), intent(in) :: t(:)
      count_pos = count(t > 0.0_rp)
    end function count_pos
    subroutine bad(what)
      character(*), intent(in) :: what
      if (e /= 0) return
      e = 1
      errmsg = 'input: '//where//': '//what
    end subroutine bad
    !> A [nt][ny][nx][3] dataset like /position, this rank's rows, into a
    !> (3, 0:nx-1, ys:ye, nt); left as it is when absent and not required.
    subroutine read_states(name, a, required)
      character(*), intent(in) :: name
      real(rp), allocatable, intent(inout) :: a(:, :, :, :)
      logical, intent(in) :: required
      logical :: ex
      if (.not. required) then
        call h5lexists_f(file, name, ex, h)
        if (h < 0 .or. .not. ex) return
      end if
      call open_dset(name, 4, .true.)
      if (e /= 0) return
      if (dims(1) /= 3 .or. dims(2) /= nx .or. dims(3) /= ny .or. dims(4) /= ntall) then
        write(errmsg, '(a,4(i0,a),3(i0,a))') 'input: '//where//': '//name//' is [', dims(4), '][', dims(3), '][', &
          dims(2), '][', dims(1), '] but the run needs [nt][ny][nx][3] = [', ntall, '][', ny, '][', nx, &
          '][3] (nt from /time, the lattice from &lattice)'
        e = 1
        call h5dclose_f(dset, h)
        return
      end if
      if (.not. allocated(a)) allocate(a(3, 0:nx - 1, ys:ys + nyl - 1, ntall))
      start = [0_hsize_t, 0_hsize_t, int(ys, hsize_t), 0_hsize_t]
      cnt = [3_hsize_t, int(nx, hsize_t), int(nyl, hsize_t), int(ntall, hsize_t)]
      call h5dget_space_f(dset, space, h)
      call h5sselect_hyperslab_f(space, H5S_SELECT_SET_F, start, cnt, h)
      call h5screate_simple_f(4, cnt, mspace, h)
      call h5dread_f(dset, H5T_NATIVE_DOUBLE, a, cnt, h, mspace, space)
      if (h < 0) call bad('cannot read '//name)
      call h5sclose_f(mspace, h)
      call h5sclose_f(space, h)
      call h5dclose_f(dset, h)
    end subroutine read_states
    subroutine open_dset(name, rank, required)
      character(*), intent(in) :: name
      integer, intent(in) :: rank
      logical, intent(in) :: required
      logical :: ex
      call h5lexists_f(file, name, ex, h)
      if (h < 0 .or. .not. ex) then
        if (required) call bad('no dataset '//name)
        return
      end if
      call h5dopen_f(file, name, dset, h)
      if (h < 0) then
        call bad('cannot open '//name)
        return
      end if
      call h5dget_space_f(dset, space, h)
      call h5sget_simple_extent_ndims_f(space, ndims, h)
      if (ndims /= rank) then
        call h5sclose_f(space, h)
        call h5dclose_f(dset, h)
        write(errmsg, '(a,i0,a,i0)') 'input: '//where//': '//name//' has ', ndims, ' dimensions, expected ', rank
        e = 1
        return
      end if
      dims = 1
      call h5sget_simple_extent_dims_f(space, dims(1:rank), maxdims(1:rank), h)
      call h5sclose_f(space, h)
    end subroutine open_dset
  end subroutine obs_read

end module identify_objective
