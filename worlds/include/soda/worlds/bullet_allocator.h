// worlds/ — one territory's physics. This header: the allocation hook that
// turns Bullet running out of memory into std::bad_alloc.
//
// Bullet allocates through btAlignedAllocInternal, which returns NULL when
// malloc does; Bullet never checks (a memset or a placement new on NULL
// follows: SIGSEGV under `ulimit -v`). install_bullet_allocator() routes
// Bullet's raw allocations through a function that throws std::bad_alloc
// instead (btAlignedAllocSetCustom: Bullet's default aligned allocator stays,
// only the malloc under it is replaced, so memory allocated before the
// install is freed correctly after it).
//
// This is process-global state (docs/bullet-globals.md): it applies to every
// Bullet user in the process, SODA's worlds and the embedding application's
// own Bullet objects alike.
#pragma once

namespace soda {

/// Installs the throwing allocator for Bullet (once per process; later calls
/// do nothing). Every SODA world constructor calls it; an application that
/// creates Bullet objects of its own before any SODA world may call it
/// first. Thread-safe (std::call_once). After it, an allocation Bullet cannot
/// get throws std::bad_alloc out of the Bullet call that needed it; the
/// object being built is then unusable and must only be destroyed.
void install_bullet_allocator();

/// True once install_bullet_allocator() has run (tests).
bool bullet_allocator_installed();

}  // namespace soda
