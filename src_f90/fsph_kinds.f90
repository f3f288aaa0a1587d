!> Working precision and physical/mathematical constants shared by every module.
module fsph_kinds
  use, intrinsic :: iso_fortran_env, only: real64
  implicit none
  private

  !> Working real kind: IEEE double precision.
  integer, parameter, public :: wp = real64
  !> pi and 2 pi (dimensionless).
  real(wp), parameter, public :: pi = 3.14159265358979323846264338327950288_wp
  real(wp), parameter, public :: two_pi = 2.0_wp*pi
  !> 1/3, so that thirds are multiplications (a division costs several) [-].
  real(wp), parameter, public :: one_third = 1.0_wp/3.0_wp
  !> Ratio used to recognise nodes lying on the symmetry axis r = 0, relative
  !> to the radial extent of the mesh (dimensionless).
  real(wp), parameter, public :: axis_tolerance = 1.0e-9_wp
end module fsph_kinds
