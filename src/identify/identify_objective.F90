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
  use strings, only: itoa
  use small_sort, only: insertion_sort
  use lattice, only: lattice_t
  use constraints, only: constraint_set_t, constraint_events
  implicit none
  private
  public :: ident_obs_t, obs_read, obs_windows, obs_residuals, obs_adjoint_terms, obs_gauss_newton
  public :: obs_n_windows, obs_window, obs_sizes, obs_last_residuals

  !> The observation or target (owned rows only), the windows and the
  !> residuals of the last forward run; written only by this module.
  type :: ident_obs_t
    private
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

  !> An observation file being read by obs_read: its handles, the
  !> dimensions of the dataset opened last and whether an error was met.
  type :: obs_file_t
    integer(hid_t) :: file = -1
    integer(hid_t) :: dset = -1
    integer(hsize_t) :: dims(4) = 1              !< of the dataset opened last, fastest first
    integer :: e = 0                             !< 1 after the first error (its message in obs_read's errmsg)
    character(len=:), allocatable :: where       !< the namelist key and the file, for messages
  end type obs_file_t

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

  !> Identification's uncertainty: the Gauss-Newton matrix of the data
  !> term, hmat(k, l) += 2 sum_t w_t sum_nodes mask a(:, :, :, t, k) a(:, :, :, t, l),
  !> with a (3, 0:nx-1, ys:ye, nt, np) the sensitivities of the residuals
  !> (this rank's rows: the caller sums over the ranks).
  subroutine obs_gauss_newton(o, a, hmat)
    type(ident_obs_t), intent(in) :: o
    real(rp), intent(in) :: a(:, :, :, :, :)
    real(rp), intent(inout) :: hmat(:, :)
    integer :: k, l, kt
    do k = 1, size(hmat, 1)
      do l = 1, size(hmat, 2)
        do kt = 1, o%nt
          hmat(k, l) = hmat(k, l) + 2.0_rp * o%wt(kt) * &
            sum(spread(o%mask, 1, 3) * a(:, :, :, kt, k) * a(:, :, :, kt, l))
        end do
      end do
    end do
  end subroutine obs_gauss_newton

  !> Time windows of a forward run.
  pure integer function obs_n_windows(o)
    type(ident_obs_t), intent(in) :: o
    obs_n_windows = o%nw
  end function obs_n_windows

  !> Window w: its start ta and end tb [time], and the observed time at its
  !> end (kobs, an index into the observed times; 0: none).
  pure subroutine obs_window(o, w, ta, tb, kobs)
    type(ident_obs_t), intent(in) :: o
    integer, intent(in) :: w
    real(rp), intent(out) :: ta, tb
    integer, intent(out) :: kobs
    ta = o%wa(w)
    tb = o%wb(w)
    kobs = o%wobs(w)
  end subroutine obs_window

  !> Observed times used (t > 0), and the scalar observations with weight
  !> > 0 (all ranks).
  pure subroutine obs_sizes(o, nt, nobs)
    type(ident_obs_t), intent(in) :: o
    integer, intent(out) :: nt
    real(rp), intent(out) :: nobs
    nt = o%nt
    nobs = o%nobs
  end subroutine obs_sizes

  !> x - xobs of the last forward run (3, 0:nx-1, ys:ye, nt) [length].
  pure function obs_last_residuals(o) result(r)
    type(ident_obs_t), intent(in) :: o
    real(rp), allocatable :: r(:, :, :, :)
    r = o%res
  end function obs_last_residuals

  !> Sort ascending and drop values within eps of the previous one.
  subroutine sort_unique(a, eps)
    real(rp), allocatable, intent(inout) :: a(:)
    real(rp), intent(in) :: eps
    real(rp), allocatable :: b(:)
    integer :: i
    call insertion_sort(a)
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
    type(obs_file_t) :: f
    integer :: h, ntall, mpierr
    real(rp), allocatable :: tall(:), wall(:), pall(:, :, :, :), vall(:, :, :, :), m2(:, :)

    o%vweight = vweight
    f%where = '&'//group//': '//key//" '"//path//"'"
    ntall = 0          ! sizes the /weight buffer even when /time was never read
    errmsg = ''
    call h5open_f(h)
    call obs_file_open(f, path, errmsg)
    call read_times(f, tall, ntall, errmsg)
    ! /position, this rank's rows; /velocity (optional) as /position, when
    ! the objective has a velocity term (control's velocity_weight)
    if (f%e == 0) call read_states(f, '/position', lat, ntall, pall, .true., errmsg)
    if (f%e == 0) then
      allocate(vall(3, 0:lat%nx - 1, lat%ys:lat%ye, ntall))
      vall = 0.0_rp
      if (o%vweight > 0.0_rp) call read_states(f, '/velocity', lat, ntall, vall, .false., errmsg)
    end if
    allocate(m2(0:lat%nx - 1, 0:lat%ny - 1))
    m2 = 1.0_rp
    call read_mask(f, m2, errmsg)
    allocate(wall(max(ntall, 0)))
    wall = 1.0_rp
    call read_weight(f, wall, errmsg)
    if (f%file >= 0) call h5fclose_f(f%file, h)
    if (f%e == 0) call check_values(f, tall, wall, m2, pall, vall, errmsg)
    ! One decision for all ranks.
    call MPI_Allreduce(MPI_IN_PLACE, f%e, 1, MPI_INTEGER, MPI_MAX, comm, mpierr)
    if (f%e /= 0) then
      ierr = 1
      if (len_trim(errmsg) == 0) errmsg = 'input: '//f%where//': could not be read on some rank'
      return
    end if
    ierr = 0
    call obs_keep(o, lat, tall, wall, m2, pall, vall)
  end subroutine obs_read

  !> The file of obs_read opened read-only, or the first error.
  subroutine obs_file_open(f, path, errmsg)
    type(obs_file_t), intent(inout) :: f
    character(*), intent(in) :: path
    character(*), intent(inout) :: errmsg
    logical :: exists
    integer :: h
    inquire(file=path, exist=exists)
    if (.not. exists) then
      f%e = 1
      errmsg = 'input: '//f%where//': no such file'
      return
    end if
    ! HDF5's own error printing stays off: the line below says it (a file
    ! that is not HDF5 made a 33-line stack before it).
    call h5eset_auto_f(0, h)
    call h5fopen_f(path, H5F_ACC_RDONLY_F, f%file, h)
    if (h < 0) then
      f%e = 1
      errmsg = 'input: '//f%where//': not an HDF5 file (or not readable)'
    end if
  end subroutine obs_file_open

  !> /time [nt], all of it (ntall times).
  subroutine read_times(f, tall, ntall, errmsg)
    type(obs_file_t), intent(inout) :: f
    real(rp), allocatable, intent(out) :: tall(:)
    integer, intent(inout) :: ntall
    character(*), intent(inout) :: errmsg
    integer :: h
    if (f%e /= 0) return
    call open_dset(f, '/time', 1, errmsg)
    if (f%e /= 0) return
    ntall = int(f%dims(1))
    allocate(tall(ntall))
    call h5dread_f(f%dset, H5T_NATIVE_DOUBLE, tall, f%dims(1:1), h)
    call read_done(f, '/time', h, errmsg)
  end subroutine read_times

  !> A [nt][ny][nx][3] dataset like /position, this rank's rows, into a
  !> (3, 0:nx-1, ys:ye, nt); left as it is when absent and not required.
  subroutine read_states(f, name, lat, ntall, a, required, errmsg)
    type(obs_file_t), intent(inout) :: f
    character(*), intent(in) :: name
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: ntall                 !< times of /time
    real(rp), allocatable, intent(inout) :: a(:, :, :, :)
    logical, intent(in) :: required
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: space, mspace
    integer(hsize_t) :: start(4), cnt(4)
    integer :: h, hc, nyl
    logical :: ex
    if (.not. required) then
      call h5lexists_f(f%file, name, ex, h)
      if (h < 0 .or. .not. ex) return
    end if
    call open_dset(f, name, 4, errmsg)
    if (f%e /= 0) return
    if (any(f%dims /= [3, lat%nx, lat%ny, ntall])) then
      write(errmsg, '(a,4(i0,a),3(i0,a))') 'input: '//f%where//': '//name//' is [', f%dims(4), '][', f%dims(3), '][', &
        f%dims(2), '][', f%dims(1), '] but the run needs [nt][ny][nx][3] = [', ntall, '][', lat%ny, '][', lat%nx, &
        '][3] (nt from /time, the lattice from &lattice)'
      f%e = 1
      call h5dclose_f(f%dset, h)
      return
    end if
    nyl = lat%ye - lat%ys + 1
    if (.not. allocated(a)) allocate(a(3, 0:lat%nx - 1, lat%ys:lat%ye, ntall))
    start = [0_hsize_t, 0_hsize_t, int(lat%ys, hsize_t), 0_hsize_t]
    cnt = [3_hsize_t, int(lat%nx, hsize_t), int(nyl, hsize_t), int(ntall, hsize_t)]
    call h5dget_space_f(f%dset, space, hc)
    call h5sselect_hyperslab_f(space, H5S_SELECT_SET_F, start, cnt, hc)
    call h5screate_simple_f(4, cnt, mspace, hc)
    call h5dread_f(f%dset, H5T_NATIVE_DOUBLE, a, cnt, h, mspace, space)
    call h5sclose_f(mspace, hc)
    call h5sclose_f(space, hc)
    call read_done(f, name, h, errmsg)
  end subroutine read_states

  !> Optional /mask [ny][nx] into m2 (0:nx-1, 0:ny-1), left as it is when absent.
  subroutine read_mask(f, m2, errmsg)
    type(obs_file_t), intent(inout) :: f
    real(rp), intent(inout) :: m2(0:, 0:)
    character(*), intent(inout) :: errmsg
    integer :: h
    logical :: found
    call open_optional(f, '/mask', [size(m2, 1), size(m2, 2)], 'input: '//f%where//': /mask must be [ny][nx] = ['// &
                       itoa(size(m2, 2))//']['//itoa(size(m2, 1))//']', errmsg, found)
    if (.not. found) return
    call h5dread_f(f%dset, H5T_NATIVE_DOUBLE, m2, f%dims(1:2), h)
    call read_done(f, '/mask', h, errmsg)
  end subroutine read_mask

  !> Optional /weight [nt] (nt of /time) into wall, left as it is when absent.
  subroutine read_weight(f, wall, errmsg)
    type(obs_file_t), intent(inout) :: f
    real(rp), intent(inout) :: wall(:)
    character(*), intent(inout) :: errmsg
    integer :: h
    logical :: found
    call open_optional(f, '/weight', [size(wall)], 'input: '//f%where//': /weight must be [nt] = ['// &
                       itoa(size(wall))//'] like /time', errmsg, found)
    if (.not. found) return
    call h5dread_f(f%dset, H5T_NATIVE_DOUBLE, wall, f%dims(1:1), h)
    call read_done(f, '/weight', h, errmsg)
  end subroutine read_weight

  !> The checks of the values read, the same on every rank.
  subroutine check_values(f, tall, wall, m2, pall, vall, errmsg)
    type(obs_file_t), intent(inout) :: f
    real(rp), intent(in) :: tall(:), wall(:), m2(:, :), pall(:, :, :, :), vall(:, :, :, :)
    character(*), intent(inout) :: errmsg
    integer :: ntall
    ntall = size(tall)
    f%e = 1
    if (any(m2 /= m2) .or. any(m2 < 0.0_rp) .or. any(wall /= wall) .or. any(wall < 0.0_rp)) then
      errmsg = 'input: '//f%where//': /mask and /weight must be finite and >= 0'
    else if (any(tall(2:) <= tall(:ntall - 1))) then
      errmsg = 'input: '//f%where//': /time must increase'
    else if (count_pos(tall) == 0) then
      errmsg = 'input: '//f%where//': no observed time > 0'
    else if (any(pall /= pall) .or. any(vall /= vall)) then
      errmsg = 'input: '//f%where//': /position or /velocity holds NaN'
    else
      f%e = 0
    end if
  end subroutine check_values

  !> The observation kept: the times > 0, their weights and states, and
  !> this rank's rows of the mask.
  subroutine obs_keep(o, lat, tall, wall, m2, pall, vall)
    type(ident_obs_t), intent(inout) :: o
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: tall(:), wall(:), m2(0:, 0:)
    real(rp), intent(in) :: pall(:, 0:, lat%ys:, :), vall(:, 0:, lat%ys:, :)
    integer :: k, n
    n = count_pos(tall)
    o%nt = n
    allocate(o%tobs(n), o%wt(n), o%xobs(3, 0:lat%nx - 1, lat%ys:lat%ye, n))
    if (o%vweight > 0.0_rp) allocate(o%vobs, mold=o%xobs)
    n = 0
    do k = 1, size(tall)
      if (tall(k) <= 0.0_rp) cycle
      n = n + 1
      o%tobs(n) = tall(k)
      o%wt(n) = wall(k)
      o%xobs(:, :, :, n) = pall(:, :, :, k)
      if (o%vweight > 0.0_rp) o%vobs(:, :, :, n) = vall(:, :, :, k)
    end do
    allocate(o%mask(0:lat%nx - 1, lat%ys:lat%ye))
    o%mask = m2(:, lat%ys:lat%ye)
    o%nobs = 3.0_rp * real(count(m2 > 0.0_rp), rp) * real(count(o%wt > 0.0_rp), rp)
  end subroutine obs_keep

  !> Times > 0 in t.
  pure integer function count_pos(t)
    real(rp), intent(in) :: t(:)
    count_pos = count(t > 0.0_rp)
  end function count_pos

  !> The first error of reading f: 'cannot read NAME' and so on.
  subroutine bad(f, what, errmsg)
    type(obs_file_t), intent(inout) :: f
    character(*), intent(in) :: what
    character(*), intent(inout) :: errmsg
    if (f%e /= 0) return
    f%e = 1
    errmsg = 'input: '//f%where//': '//what
  end subroutine bad

  !> After reading dataset `name` (h: the read's code): its error, and the
  !> dataset closed.
  subroutine read_done(f, name, h, errmsg)
    type(obs_file_t), intent(inout) :: f
    character(*), intent(in) :: name
    integer, intent(in) :: h
    character(*), intent(inout) :: errmsg
    integer :: hc
    if (h < 0) call bad(f, 'cannot read '//name, errmsg)
    call h5dclose_f(f%dset, hc)
  end subroutine read_done

  !> Dataset `name`, which must exist, opened in f%dset with its
  !> dimensions in f%dims (HDF5's order reversed: fastest first); an error
  !> when it is absent or has not `rank` dimensions.
  subroutine open_dset(f, name, rank, errmsg)
    type(obs_file_t), intent(inout) :: f
    character(*), intent(in) :: name
    integer, intent(in) :: rank
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: space
    integer(hsize_t) :: maxdims(4)
    integer :: h, ndims
    logical :: ex
    call h5lexists_f(f%file, name, ex, h)
    if (h < 0 .or. .not. ex) then
      call bad(f, 'no dataset '//name, errmsg)
      return
    end if
    call h5dopen_f(f%file, name, f%dset, h)
    if (h < 0) then
      call bad(f, 'cannot open '//name, errmsg)
      return
    end if
    call h5dget_space_f(f%dset, space, h)
    call h5sget_simple_extent_ndims_f(space, ndims, h)
    if (ndims /= rank) then
      call h5sclose_f(space, h)
      call h5dclose_f(f%dset, h)
      write(errmsg, '(a,i0,a,i0)') 'input: '//f%where//': '//name//' has ', ndims, ' dimensions, expected ', rank
      f%e = 1
      return
    end if
    f%dims = 1
    call h5sget_simple_extent_dims_f(space, f%dims(1:rank), maxdims(1:rank), h)
    call h5sclose_f(space, h)
  end subroutine open_dset

  !> An optional dataset: found (open in f%dset) when present with the
  !> dimensions want (fastest first); an error (shape_msg) when present
  !> with others. Nothing after an error.
  subroutine open_optional(f, name, want, shape_msg, errmsg, found)
    type(obs_file_t), intent(inout) :: f
    character(*), intent(in) :: name, shape_msg
    integer, intent(in) :: want(:)
    character(*), intent(inout) :: errmsg
    logical, intent(out) :: found
    integer :: h
    found = .false.
    if (f%e /= 0) return
    call h5lexists_f(f%file, name, found, h)
    if (.not. found) return
    found = .false.
    call open_dset(f, name, size(want), errmsg)
    if (f%e /= 0) return
    if (any(f%dims(1:size(want)) /= want)) then
      errmsg = shape_msg
      f%e = 1
      call h5dclose_f(f%dset, h)
      return
    end if
    found = .true.
  end subroutine open_optional

end module identify_objective
