!> Helpers that resize, append to and compact allocatable arrays whose last
!> dimension runs over items (nodes, elements, particles). compact, append
!> and reset_size are used only when the discretisation changes
!> (conversion); reserve keeps the cycle's work arrays, which only grow, so
!> an ordinary cycle allocates nothing.
module fsph_arrays
  use fsph_kinds, only: wp
  implicit none
  private

  !> Keep the items where mask is true, in order.
  public :: compact
  interface compact
    module procedure compact_r1, compact_r2, compact_i1, compact_i2, compact_l1
  end interface compact

  !> Append the items of b after those of a.
  public :: append
  interface append
    module procedure append_r1, append_r2, append_i1, append_i2
  end interface append

  !> Make a work array hold at least n items (a rank-2 array: m by n),
  !> reallocating it (contents lost) only when it is unallocated or too
  !> small; a larger array is kept as it is.
  public :: reserve
  interface reserve
    module procedure reserve_r1, reserve_r2, reserve_i1, reserve_l1
  end interface reserve

  !> Resize an allocated array to n items (its last dimension), keeping
  !> the first min(old, n) items and zeroing the rest (the particle arrays
  !> when mirror images need more room than was reserved).
  public :: grow
  interface grow
    module procedure grow_r1, grow_r2, grow_r3, grow_i1, grow_i2, grow_l1
  end interface grow

  !> Reallocate to n items (contents discarded, set to zero).
  public :: reset_size
  interface reset_size
    module procedure reset_r1, reset_r2, reset_i1
  end interface reset_size

contains

  subroutine reserve_r1(a, n)
    real(wp), allocatable, intent(inout) :: a(:)
    integer, intent(in) :: n
    if (allocated(a)) then
      if (size(a) >= n) return
      deallocate (a)
    end if
    allocate (a(n))
  end subroutine reserve_r1

  subroutine reserve_r2(a, m, n)
    real(wp), allocatable, intent(inout) :: a(:, :)
    integer, intent(in) :: m, n
    if (allocated(a)) then
      if (size(a, 1) == m .and. size(a, 2) >= n) return
      deallocate (a)
    end if
    allocate (a(m, n))
  end subroutine reserve_r2

  subroutine reserve_i1(a, n)
    integer, allocatable, intent(inout) :: a(:)
    integer, intent(in) :: n
    if (allocated(a)) then
      if (size(a) >= n) return
      deallocate (a)
    end if
    allocate (a(n))
  end subroutine reserve_i1

  subroutine reserve_l1(a, n)
    logical, allocatable, intent(inout) :: a(:)
    integer, intent(in) :: n
    if (allocated(a)) then
      if (size(a) >= n) return
      deallocate (a)
    end if
    allocate (a(n))
  end subroutine reserve_l1

  subroutine compact_r1(a, mask)
    real(wp), allocatable, intent(inout) :: a(:)
    logical, intent(in) :: mask(:)
    a = pack(a, mask)
  end subroutine compact_r1

  subroutine compact_r2(a, mask)
    real(wp), allocatable, intent(inout) :: a(:, :)
    logical, intent(in) :: mask(:)
    real(wp), allocatable :: b(:, :)
    integer :: k, m
    allocate (b(size(a, 1), count(mask)))
    m = 0
    do k = 1, size(mask)
      if (.not. mask(k)) cycle
      m = m + 1
      b(:, m) = a(:, k)
    end do
    call move_alloc(b, a)
  end subroutine compact_r2

  subroutine compact_i1(a, mask)
    integer, allocatable, intent(inout) :: a(:)
    logical, intent(in) :: mask(:)
    a = pack(a, mask)
  end subroutine compact_i1

  subroutine compact_l1(a, mask)
    logical, allocatable, intent(inout) :: a(:)
    logical, intent(in) :: mask(:)
    a = pack(a, mask)
  end subroutine compact_l1

  subroutine compact_i2(a, mask)
    integer, allocatable, intent(inout) :: a(:, :)
    logical, intent(in) :: mask(:)
    integer, allocatable :: b(:, :)
    integer :: k, m
    allocate (b(size(a, 1), count(mask)))
    m = 0
    do k = 1, size(mask)
      if (.not. mask(k)) cycle
      m = m + 1
      b(:, m) = a(:, k)
    end do
    call move_alloc(b, a)
  end subroutine compact_i2

  subroutine append_r1(a, b)
    real(wp), allocatable, intent(inout) :: a(:)
    real(wp), intent(in) :: b(:)
    a = [a, b]
  end subroutine append_r1

  subroutine append_i1(a, b)
    integer, allocatable, intent(inout) :: a(:)
    integer, intent(in) :: b(:)
    a = [a, b]
  end subroutine append_i1

  subroutine append_r2(a, b)
    real(wp), allocatable, intent(inout) :: a(:, :)
    real(wp), intent(in) :: b(:, :)
    real(wp), allocatable :: c(:, :)
    integer :: n
    n = size(a, 2)
    allocate (c(size(a, 1), n + size(b, 2)))
    c(:, 1:n) = a
    c(:, n + 1:) = b
    call move_alloc(c, a)
  end subroutine append_r2

  subroutine append_i2(a, b)
    integer, allocatable, intent(inout) :: a(:, :)
    integer, intent(in) :: b(:, :)
    integer, allocatable :: c(:, :)
    integer :: n
    n = size(a, 2)
    allocate (c(size(a, 1), n + size(b, 2)))
    c(:, 1:n) = a
    c(:, n + 1:) = b
    call move_alloc(c, a)
  end subroutine append_i2

  subroutine grow_r1(a, n)
    real(wp), allocatable, intent(inout) :: a(:)
    integer, intent(in) :: n
    real(wp), allocatable :: b(:)
    integer :: k
    allocate (b(n))
    b = 0.0_wp
    k = min(n, size(a))
    b(1:k) = a(1:k)
    call move_alloc(b, a)
  end subroutine grow_r1

  subroutine grow_r2(a, n)
    real(wp), allocatable, intent(inout) :: a(:, :)
    integer, intent(in) :: n
    real(wp), allocatable :: b(:, :)
    integer :: k
    allocate (b(size(a, 1), n))
    b = 0.0_wp
    k = min(n, size(a, 2))
    b(:, 1:k) = a(:, 1:k)
    call move_alloc(b, a)
  end subroutine grow_r2

  subroutine grow_r3(a, n)
    real(wp), allocatable, intent(inout) :: a(:, :, :)
    integer, intent(in) :: n
    real(wp), allocatable :: b(:, :, :)
    integer :: k
    allocate (b(size(a, 1), size(a, 2), n))
    b = 0.0_wp
    k = min(n, size(a, 3))
    b(:, :, 1:k) = a(:, :, 1:k)
    call move_alloc(b, a)
  end subroutine grow_r3

  subroutine grow_i1(a, n)
    integer, allocatable, intent(inout) :: a(:)
    integer, intent(in) :: n
    integer, allocatable :: b(:)
    integer :: k
    allocate (b(n))
    b = 0
    k = min(n, size(a))
    b(1:k) = a(1:k)
    call move_alloc(b, a)
  end subroutine grow_i1

  subroutine grow_i2(a, n)
    integer, allocatable, intent(inout) :: a(:, :)
    integer, intent(in) :: n
    integer, allocatable :: b(:, :)
    integer :: k
    allocate (b(size(a, 1), n))
    b = 0
    k = min(n, size(a, 2))
    b(:, 1:k) = a(:, 1:k)
    call move_alloc(b, a)
  end subroutine grow_i2

  subroutine grow_l1(a, n)
    logical, allocatable, intent(inout) :: a(:)
    integer, intent(in) :: n
    logical, allocatable :: b(:)
    integer :: k
    allocate (b(n))
    b = .false.
    k = min(n, size(a))
    b(1:k) = a(1:k)
    call move_alloc(b, a)
  end subroutine grow_l1

  subroutine reset_r1(a, n)
    real(wp), allocatable, intent(inout) :: a(:)
    integer, intent(in) :: n
    if (allocated(a)) deallocate (a)
    allocate (a(n))
    a = 0.0_wp
  end subroutine reset_r1

  subroutine reset_r2(a, m, n)
    real(wp), allocatable, intent(inout) :: a(:, :)
    integer, intent(in) :: m, n
    if (allocated(a)) deallocate (a)
    allocate (a(m, n))
    a = 0.0_wp
  end subroutine reset_r2

  subroutine reset_i1(a, n)
    integer, allocatable, intent(inout) :: a(:)
    integer, intent(in) :: n
    if (allocated(a)) deallocate (a)
    allocate (a(n))
    a = 0
  end subroutine reset_i1

end module fsph_arrays
