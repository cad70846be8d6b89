! SPDX-License-Identifier: BSD-2-Clause
!> The checks of &contact after it is read (module input_checks' validate
!> calls check_contact): the barrier's parameters, each obstacle's shape
!> and keyframed motion, obstacles described beyond n_obstacles, the
!> barrier's scales against the lattice spacing, the masses and the step
!> (input/README.md, &contact). No MPI, no PETSc: every rank reaches the
!> same result alone.
module input_contact_checks
  use kinds, only: rp
  use config, only: nuno_config, contact_config, obstacle_keyframe_max, obstacle_max, MASS_AREA
  use input_text, only: lower
  use strings, only: real_short, itoa
  use contact, only: barrier
  use input_bounds, only: choices, check_choice, need_positive, need_nonnegative
  implicit none
  private
  public :: check_contact

contains

  !> &contact: the barrier's parameters always (a key given is checked
  !> even without obstacles), each obstacle in use; contact with
  !> identification or control is refused (the adjoint is not exact with contact).
  subroutine check_contact(cfg, ierr, msg)
    type(nuno_config), intent(inout) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    integer :: k, code
    character(8) :: sub
    associate (c => cfg%contact)
      call need_nonnegative('contact', 'contact_thickness', c%thickness, ierr, msg); if (ierr /= 0) return
      call need_positive('contact', 'contact_dhat', c%dhat, ierr, msg);             if (ierr /= 0) return
      call need_positive('contact', 'contact_stiffness', c%stiffness, ierr, msg);   if (ierr /= 0) return
      call need_positive('contact', 'friction_eps_v', c%eps_v, ierr, msg);          if (ierr /= 0) return
      ierr = 1
      if (c%n_obstacles < 0 .or. c%n_obstacles > size(c%shape)) then
        write(msg, '(a,i0,a,i0)') 'input: &contact: n_obstacles = ', c%n_obstacles, ' must be in 0..', size(c%shape)
        return
      end if
      do k = 1, c%n_obstacles
        write(sub, '(a,i0,a)') '(', k, ')'
        c%shape(k) = lower(adjustl(c%shape(k)))
        call check_choice('contact', 'obstacle_shape'//trim(sub), c%shape(k), &
                          choices('obstacle_shape'), code, ierr, msg)
        if (ierr /= 0) return
        c%shape_code(k) = code
        ierr = 1
        if (c%mu(k) < 0.0_rp) then
          msg = 'input: &contact: obstacle_mu'//trim(sub)//' = '//real_short(c%mu(k))//' must be >= 0'
          return
        end if
        call check_obstacle_shape(c, k, ierr, msg); if (ierr /= 0) return
        call check_obstacle_motion(c, k, ierr, msg); if (ierr /= 0) return
        ierr = 1
      end do
      call check_unused_obstacles(c, ierr, msg); if (ierr /= 0) return
      if (c%n_obstacles > 0) then
        call check_contact_scales(cfg, ierr, msg); if (ierr /= 0) return
      end if
      if (c%self_contact) then
        call check_self_contact(cfg, ierr, msg); if (ierr /= 0) return
      end if
      call check_self_mu(c, ierr, msg); if (ierr /= 0) return
      call check_self_step(c, ierr, msg); if (ierr /= 0) return
      if (c%self_mu > 0.0_rp) then
        call check_eps_v_range(cfg, ierr, msg); if (ierr /= 0) return
      end if
      ierr = 1
      ! The adjoint would be inexact with contact (docs/identification.md,
      ! "Contact"): friction's lagged normal force is not differentiated, the
      ! curved obstacles' Jacobian is PSD-projected, and the step limit's
      ! retries change the step sequence with the parameters.
      if (c%n_obstacles > 0 .and. (cfg%identify%active .or. cfg%control%active)) then
        write(msg, '(a,i0,a)') 'input: &contact: n_obstacles = ', c%n_obstacles, ' is refused with '// &
          trim(merge('&identify', '&control ', cfg%identify%active))//': the adjoint gradient is not exact with contact '// &
          "(friction's lag is not differentiated; docs/identification.md)"
        return
      end if
      ierr = 0
      msg = ''
    end associate
  end subroutine check_contact

  !> self_contact = .true.: the barrier's reach between two pieces of the
  !> cloth, contact_dhat + 2 contact_thickness, below 0.7 of the smaller
  !> lattice spacing (a reach of at least that leaves pairs of lattice
  !> neighbours out of the contact and unprotected: docs/self-contact.md,
  !> "Candidate pairs"); refused with &identify and &control (the adjoint
  !> knows no self-contact).
  subroutine check_self_contact(cfg, ierr, msg)
    type(nuno_config), intent(in) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    real(rp) :: a, reach
    ierr = 1
    a = min(cfg%lattice%ax, cfg%lattice%ay)
    reach = cfg%contact%dhat + 2.0_rp * cfg%contact%thickness
    if (reach >= 0.7_rp * a) then
      msg = 'input: &contact: self_contact = .true. needs contact_dhat + 2 contact_thickness = '//real_short(reach)// &
            ' below 0.7 of the lattice spacing '//real_short(a)//': a smaller contact_dhat or contact_thickness, or a coarser lattice'
      return
    end if
    if (cfg%identify%active .or. cfg%control%active) then
      msg = 'input: &contact: self_contact = .true. is refused with '// &
            trim(merge('&identify', '&control ', cfg%identify%active))//': the adjoint gradient knows no self-contact'
      return
    end if
    ierr = 0
    msg = ''
  end subroutine check_self_contact

  !> self_mu: a number >= 0 (NaN refused), and only with self_contact
  !> (friction between layers acts on the self-contact's pairs: without
  !> them it would be ignored).
  subroutine check_self_mu(c, ierr, msg)
    type(contact_config), intent(in) :: c
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    ierr = 1
    if (.not. (c%self_mu >= 0.0_rp .and. c%self_mu <= huge(1.0_rp))) then
      msg = 'input: &contact: self_mu = '//real_short(c%self_mu)//' must be a number >= 0'
      return
    end if
    if (c%self_mu > 0.0_rp .and. .not. c%self_contact) then
      msg = 'input: &contact: self_mu = '//real_short(c%self_mu)//' needs self_contact = .true. '// &
            '(friction between layers acts on the self-contact''s pairs)'
      return
    end if
    ierr = 0
    msg = ''
  end subroutine check_self_mu

  !> self_step: 'accd' or 'ogc' (lower-cased here), and 'ogc' only with
  !> self_contact (it would be ignored).
  subroutine check_self_step(c, ierr, msg)
    type(contact_config), intent(inout) :: c
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    integer :: code
    c%self_step = lower(adjustl(c%self_step))
    call check_choice('contact', 'self_step', c%self_step, choices('self_step'), code, ierr, msg)
    if (ierr /= 0) return
    if (code /= 1 .and. .not. c%self_contact) then
      ierr = 1
      msg = "input: &contact: self_step = '"//trim(c%self_step)//"' needs self_contact = .true. "// &
            '(without it there is no self-contact step to limit)'
    end if
  end subroutine check_self_step

  !> Obstacles described beyond n_obstacles: a key of an obstacle k >
  !> n_obstacles with a value other than its default is refused by name,
  !> rather than ignored (the obstacle would not be there).
  subroutine check_unused_obstacles(c, ierr, msg)
    type(contact_config), intent(in) :: c
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    type(contact_config) :: d
    integer :: k
    character(12) :: sub, sub3, sub2
    character(:), allocatable :: what
    ierr = 0
    msg = ''
    do k = max(c%n_obstacles, 0) + 1, obstacle_max
      write(sub, '(a,i0,a)') '(', k, ')'
      write(sub3, '(a,i0,a)') '(:, ', k, ')'
      write(sub2, '(a,i0,a)') '(:, ', k, ')'
      what = ''
      if (lower(adjustl(c%shape(k))) /= lower(adjustl(d%shape(k)))) then
        what = 'obstacle_shape'//trim(sub)//' = '''//trim(adjustl(c%shape(k)))//''''
      else if (any(c%point(:, k) /= d%point(:, k))) then
        what = 'obstacle_point'//trim(sub3)//' = '//vec_text(c%point(:, k))
      else if (any(c%normal(:, k) /= d%normal(:, k))) then
        what = 'obstacle_normal'//trim(sub3)//' = '//vec_text(c%normal(:, k))
      else if (any(c%axis(:, k) /= d%axis(:, k))) then
        what = 'obstacle_axis'//trim(sub3)//' = '//vec_text(c%axis(:, k))
      else if (any(c%half_size(:, k) /= d%half_size(:, k))) then
        what = 'obstacle_half_size'//trim(sub3)//' = '//vec_text(c%half_size(:, k))
      else if (any(c%end_pt(:, k) /= d%end_pt(:, k))) then
        what = 'obstacle_end'//trim(sub3)//' = '//vec_text(c%end_pt(:, k))
      else if (c%radius(k) /= d%radius(k)) then
        what = 'obstacle_radius'//trim(sub)//' = '//real_short(c%radius(k))
      else if (c%mu(k) /= d%mu(k)) then
        what = 'obstacle_mu'//trim(sub)//' = '//real_short(c%mu(k))
      else if (c%n_keyframes(k) /= d%n_keyframes(k)) then
        what = 'obstacle_n_keyframes'//trim(sub)//' = '//itoa(c%n_keyframes(k))
      else if (any(c%key_time(:, k) /= d%key_time(:, k))) then
        what = 'obstacle_time'//trim(sub2)
      else if (any(c%key_offset(:, :, k) /= d%key_offset(:, :, k))) then
        what = 'obstacle_offset(:, :, '//itoa(k)//')'
      else if (any(c%key_close(:, k) /= d%key_close(:, k))) then
        what = 'obstacle_close'//trim(sub2)
      else if (any(c%close_dir(:, k) /= d%close_dir(:, k))) then
        what = 'obstacle_close_dir'//trim(sub3)//' = '//vec_text(c%close_dir(:, k))
      end if
      if (len(what) == 0) cycle
      ierr = 1
      msg = 'input: &contact: '//what//' describes obstacle '//itoa(k)//', beyond n_obstacles = '// &
            itoa(c%n_obstacles)//': set n_obstacles = '//itoa(k)//' (or more), or leave the key out'
      return
    end do
  end subroutine check_unused_obstacles

  !> The barrier's and friction's parameters against the scene's scales
  !> (input/README.md, "&contact", where the reasons are), a the smaller
  !> lattice spacing, m_max and m_min the heaviest and the lightest node,
  !> g0 = |gravity|, dt the step:
  !>   contact_dhat in [1e-4 a, a];
  !>   contact_stiffness at most 100 m_min / dt^2, and with gravity at
  !>     least the stiffness whose barrier holds m_max g0 at a gap of
  !>     1e-5 contact_dhat (ten times the acceptance floor);
  !>   friction_eps_v in [1e-7, 1] a / dt where some obstacle has friction
  !>   (check_eps_v_range).
  subroutine check_contact_scales(cfg, ierr, msg)
    type(nuno_config), intent(in) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    real(rp) :: a, mmax, mmin, g0, dt, lo, hi, e, de, d2e
    ierr = 1
    associate (c => cfg%contact, l => cfg%lattice)
      a = min(l%ax, l%ay)
      if (l%mass_code == MASS_AREA) then
        mmax = l%total_mass / real((l%nx - 1) * (l%ny - 1), rp)
        mmin = 0.25_rp * mmax
      else
        mmax = l%total_mass / real(l%nx * l%ny, rp)
        mmin = mmax
      end if
      g0 = norm2(cfg%scene%gravity)
      dt = cfg%time%dt
      lo = 1.0e-4_rp * a
      hi = a
      if (.not. (c%dhat >= lo .and. c%dhat <= hi)) then
        msg = 'input: &contact: contact_dhat = '//real_short(c%dhat)//' must be between 1e-4 and 1 times the '// &
              'lattice spacing '//real_short(a)//' ('//real_short(lo)//' .. '//real_short(hi)// &
              '): the barrier acts on the nodes, within a link of an obstacle (input/README.md, "&contact")'
        return
      end if
      hi = 100.0_rp * mmin / dt**2
      if (.not. (c%stiffness <= hi)) then
        msg = 'input: &contact: contact_stiffness = '//real_short(c%stiffness)//' must be at most 100 m/dt^2 = '// &
              real_short(hi)//' (m = '//real_short(mmin)//' the lightest node, dt = '//real_short(dt)// &
              '): a stiffer barrier stops Newton at every impact (input/README.md, "&contact")'
        return
      end if
      if (g0 > 0.0_rp) then
        call barrier(1.0e-5_rp * c%dhat, c%dhat, e, de, d2e)
        lo = mmax * g0 / abs(de)
        if (.not. (c%stiffness >= lo)) then
          msg = 'input: &contact: contact_stiffness = '//real_short(c%stiffness)//' must be at least '// &
                real_short(lo)//': the barrier must hold the heaviest node''s weight (m g = '//real_short(mmax * g0)// &
                ') at a gap of at least 1e-5 contact_dhat, ten times the acceptance floor (input/README.md, "&contact")'
          return
        end if
      end if
      if (any(c%mu(1:c%n_obstacles) > 0.0_rp)) then
        call check_eps_v_range(cfg, ierr, msg); if (ierr /= 0) return
        ierr = 1
      end if
    end associate
    ierr = 0
    msg = ''
  end subroutine check_contact_scales

  !> friction_eps_v in [1e-7, 1] a / dt (a the smaller lattice spacing, dt
  !> the step): friction's smoothing band, checked where some friction acts
  !> (an obstacle's obstacle_mu or self_mu > 0).
  subroutine check_eps_v_range(cfg, ierr, msg)
    type(nuno_config), intent(in) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    real(rp) :: a, dt, lo, hi
    ierr = 1
    a = min(cfg%lattice%ax, cfg%lattice%ay)
    dt = cfg%time%dt
    lo = 1.0e-7_rp * a / dt
    hi = a / dt
    if (.not. (cfg%contact%eps_v >= lo .and. cfg%contact%eps_v <= hi)) then
      msg = 'input: &contact: friction_eps_v = '//real_short(cfg%contact%eps_v)//' must be between 1e-7 and 1 times '// &
            'a/dt = '//real_short(a / dt)//' (the lattice spacing '//real_short(a)//' a step, dt = '//real_short(dt)// &
            '; '//real_short(lo)//' .. '//real_short(hi)//'): friction''s smoothing band (input/README.md, "&contact")'
      return
    end if
    ierr = 0
    msg = ''
  end subroutine check_eps_v_range

  !> Obstacle k's geometry by its shape (code: 1 plane, 2 sphere, 3 box,
  !> 4 capsule): a plane's normal and a box's axes normalised (the box's x
  !> axis orthogonalised against its normal, its local z); radii and half
  !> extents > 0.
  subroutine check_obstacle_shape(c, k, ierr, msg)
    type(contact_config), intent(inout) :: c
    integer, intent(in) :: k
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    character(12) :: sub, sub3
    real(rp) :: nn, a(3), na
    write(sub, '(a,i0,a)') '(', k, ')'
    write(sub3, '(a,i0,a)') '(:, ', k, ')'
    ierr = 1
    if (c%shape_code(k) == 1 .or. c%shape_code(k) == 3) then
      nn = norm2(c%normal(:, k))
      if (.not. (nn > 0.0_rp)) then
        msg = 'input: &contact: obstacle_normal'//trim(sub3)//' = '//vec_text(c%normal(:, k))//' must not be zero'
        return
      end if
      c%normal(:, k) = c%normal(:, k) / nn
    end if
    select case (c%shape_code(k))
    case (2, 4)
      if (.not. (c%radius(k) > 0.0_rp)) then
        msg = 'input: &contact: obstacle_radius'//trim(sub)//' = '//real_short(c%radius(k))// &
              ' must be > 0 for a '//trim(c%shape(k))
        return
      end if
    case (3)
      if (.not. all(c%half_size(:, k) > 0.0_rp)) then
        msg = 'input: &contact: obstacle_half_size'//trim(sub3)//' = '//vec_text(c%half_size(:, k))// &
              ' must be > 0 (each) for a box'
        return
      end if
      ! the box's local x: the given axis less its part along the normal (local z)
      a = c%axis(:, k) - dot_product(c%axis(:, k), c%normal(:, k)) * c%normal(:, k)
      na = norm2(a)
      if (.not. (na > 1.0e-6_rp * norm2(c%axis(:, k)))) then
        msg = 'input: &contact: obstacle_axis'//trim(sub3)//' = '//vec_text(c%axis(:, k))// &
              ' must not be zero nor parallel to obstacle_normal'//trim(sub3)//' = '//vec_text(c%normal(:, k))
        return
      end if
      c%axis(:, k) = a / na
    end select
    ierr = 0
    msg = ''
  end subroutine check_obstacle_shape

  !> Obstacle k's keyframes: 0..obstacle_keyframe_max of them, times >= 0
  !> and strictly increasing, a closing direction (normalised) where a
  !> closing offset is given; offsets beyond the keyframes in use are
  !> refused rather than ignored.
  subroutine check_obstacle_motion(c, k, ierr, msg)
    type(contact_config), intent(inout) :: c
    integer, intent(in) :: k
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    character(24) :: sub, sub2
    integer :: nk, j
    real(rp) :: nd
    nk = c%n_keyframes(k)
    write(sub, '(a,i0,a)') '(', k, ')'
    ierr = 1
    if (nk < 0 .or. nk > obstacle_keyframe_max) then
      write(msg, '(a,i0,a,i0)') 'input: &contact: obstacle_n_keyframes'//trim(sub)//' = ', nk, ' must be in 0..', &
        obstacle_keyframe_max
      return
    end if
    do j = 1, nk
      write(sub2, '(a,i0,a,i0,a)') '(', j, ', ', k, ')'
      if (c%key_time(j, k) < 0.0_rp .or. (j > 1 .and. .not. (c%key_time(j, k) > c%key_time(max(j - 1, 1), k)))) then
        msg = 'input: &contact: obstacle_time'//trim(sub2)//' = '//real_short(c%key_time(j, k))// &
              ' must be >= 0 and greater than the keyframe before'
        return
      end if
    end do
    do j = nk + 1, obstacle_keyframe_max
      write(sub2, '(a,i0,a,i0,a)') '(', j, ', ', k, ')'
      if (c%key_time(j, k) /= 0.0_rp) then
        write(msg, '(a,i0,a)') 'input: &contact: obstacle_time'//trim(sub2)//' = '//real_short(c%key_time(j, k))// &
          ' is beyond obstacle_n_keyframes'//trim(sub)//' = ', nk, ': set obstacle_n_keyframes'
        return
      end if
      write(sub2, '(a,i0,a,i0,a)') '(:, ', j, ', ', k, ')'
      if (any(c%key_offset(:, j, k) /= 0.0_rp)) then
        write(msg, '(a,i0,a)') 'input: &contact: obstacle_offset'//trim(sub2)//' = '//vec_text(c%key_offset(:, j, k))// &
          ' is beyond obstacle_n_keyframes'//trim(sub)//' = ', nk, ': set obstacle_n_keyframes'
        return
      end if
      write(sub2, '(a,i0,a,i0,a)') '(', j, ', ', k, ')'
      if (c%key_close(j, k) /= 0.0_rp) then
        write(msg, '(a,i0,a)') 'input: &contact: obstacle_close'//trim(sub2)//' = '//real_short(c%key_close(j, k))// &
          ' is beyond obstacle_n_keyframes'//trim(sub)//' = ', nk, ': set obstacle_n_keyframes'
        return
      end if
    end do
    if (any(c%key_close(1:nk, k) /= 0.0_rp)) then
      nd = norm2(c%close_dir(:, k))
      if (.not. (nd > 0.0_rp)) then
        write(sub2, '(a,i0,a)') '(:, ', k, ')'
        msg = 'input: &contact: obstacle_close_dir'//trim(sub2)//' = '//vec_text(c%close_dir(:, k))// &
              ' must not be zero: obstacle '//trim(adjustl(sub(2:len_trim(sub) - 1)))//' has closing offsets'
        return
      end if
      c%close_dir(:, k) = c%close_dir(:, k) / nd
    end if
    ierr = 0
    msg = ''
  end subroutine check_obstacle_motion

  !> "a, b, c" of a 3-vector, as the namelist would write it back short.
  function vec_text(v) result(s)
    real(rp), intent(in) :: v(3)
    character(:), allocatable :: s
    s = real_short(v(1))//', '//real_short(v(2))//', '//real_short(v(3))
  end function vec_text

end module input_contact_checks
