// runtime/ — the public embedding API. This header: contact events, read per
// committed step from every world's transform buffer. Include
// soda/runtime/simulation.h, which brings it.
//
// With SimulationConfig::contact_events on, every world records after each
// scene step the contact state of the pairs it reports (a pair is reported
// by the owner of its key body: exactly one world for any partition) in the
// step's entry of its transform buffer. A ContactReader joins the K records
// of one step and diffs them against the previous step's: a pair whose
// manifold holds points at step t and did not at t - 1 begins at t; one that
// held points at t - 1 and holds none at t ends at t; one that holds points
// at both persists. Only final steps are served (no rollback can change
// them), so no event ever comes from a step that is later rolled back; the
// stream is bit-identical for any number of territories, partition,
// schedule or speculation (docs/contact-events.md).
//
//   soda::Simulation sim(scene, {.territories = 4, .contact_events = true});
//   soda::ContactReader contacts = sim.add_contact_reader();
//   sim.start(5.0);
//   for (std::int64_t s = 1; s <= sim.step_at(5.0); ++s)
//     if (auto step = contacts.read_step(s))              // waits for step s
//       for (const soda::ContactEvent& e : step->events)
//         if (e.kind == soda::ContactEventKind::Begin && e.total_impulse() > 2) clack(e);
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include <LinearMath/btScalar.h>

#include "soda/rollback/transform_buffer.h"
#include "soda/rollback/transform_entry.h"

namespace soda {

/// One contact point at the end of a step (transform_entry.h): the points on
/// a and on b, the normal on b (unit, from b towards a), the distance (< 0:
/// penetrating) and the normal impulse the step's solve applied (N s), in
/// the precision Bullet was built with.
using ContactEventPoint = PairContactPoint<btScalar>;

enum class ContactEventKind : std::uint8_t {
  Begin = 0,    // points at this step, none at the step before
  Persist = 1,  // points at both (only when asked for)
  End = 2,      // none at this step, points at the step before
};

/// "begin", "persist" or "end".
const char* to_string(ContactEventKind kind);

/// What happened to one pair of bodies at one committed step.
struct ContactEvent {
  std::int64_t step = 0;  // the scene step it ended at
  ContactEventKind kind = ContactEventKind::Begin;
  BodyId a = 0;  // a < b: Bullet's body0 and body1 of the pair's manifold
  BodyId b = 0;
  /// Points held at the end of `step` (1 to 4, Bullet's cache order); 0 for
  /// an End event.
  std::uint32_t point_count = 0;
  ContactEventPoint points[4];
  /// Sum of the points' impulses, in point order (0 for End).
  btScalar total_impulse() const;
};

/// Every event of one committed step, ascending by (a, b) (a pair has at
/// most one event per step).
struct ContactStep {
  std::int64_t step = 0;
  double time = 0.0;  // step * dt, s
  std::vector<ContactEvent> events;
};

/// 64-bit FNV-1a over the events (step, kind, ids, point count and every
/// point's bits) of `steps` in order: equal streams, equal hashes. Pure.
std::uint64_t contact_stream_hash(const std::vector<ContactStep>& steps);

struct SimulationCore;  // internal

/// A cursor into every world's transform buffer that reads contact events,
/// made by Simulation::add_contact_reader(). Like a SceneReader, it holds
/// the entries at and after its last step (back-pressure: a reader that
/// does not read slows the run down once the buffers are full); destroy it
/// when done. It does not hold the commit horizon (past inputs may still
/// name steps it read before they were final: it never reads such a step).
///
/// Reads go forward: read_step(s) for s after the last step read; the last
/// step read may be read again (the same events); an earlier one is gone.
///
/// Thread safety: one thread at a time per reader; readers and the
/// Simulation's calls may run concurrently. A reader may outlive its
/// Simulation: reads then serve what is still held, and never wait.
class ContactReader {
 public:
  ContactReader(ContactReader&&) noexcept;
  ContactReader& operator=(ContactReader&&) noexcept;
  ContactReader(const ContactReader&) = delete;
  ContactReader& operator=(const ContactReader&) = delete;
  /// Unregisters from every buffer. Any thread but the one reading with it.
  ~ContactReader();

  /// The events of scene step `step`, once every world has published it and
  /// it is final (waits). The first step of the run (0, or a snapshot's)
  /// begins every pair in contact there. nullopt if the step is gone (before
  /// the last step read, or it or the step before it freed — a reader made
  /// late finds the steps freed before it was made), or the Simulation was
  /// stopped before it was published. Throws SimulationError if a world failed while it
  /// waited, std::logic_error if contact events are off or two worlds
  /// report one pair, std::invalid_argument for a step before the run's
  /// first. Reader's thread.
  std::optional<ContactStep> read_step(std::int64_t step);

  /// As read_step, but never waits: nullopt also when the step is not
  /// final yet. Reader's thread.
  std::optional<ContactStep> try_read_step(std::int64_t step);

  /// read_step(last_step() + 1) (the run's first step before any read).
  std::optional<ContactStep> read_next();

  /// Step of the last events this reader returned; -1 before its first
  /// read. Reader's thread.
  std::int64_t last_step() const { return last_step_; }

  /// Whether Persist events are reported (set at add_contact_reader).
  bool persist() const { return persist_; }

 private:
  friend class Simulation;
  friend class SimulationEngine;
  ContactReader(std::shared_ptr<SimulationCore> core, bool persist);
  std::optional<ContactStep> read(std::int64_t step, bool wait);
  void release() noexcept;

  std::shared_ptr<SimulationCore> core_;
  std::vector<BufferReaderId> ids_;  // one per world
  bool persist_ = false;
  std::int64_t last_step_ = -1;
  ContactStep last_;                                 // the events of last_step_
  std::int64_t held_step_ = -1;                      // the step whose contacts held_ are; -1: none
  std::vector<PairContact<btScalar>> held_;          // every world's contacts of held_step_, by pair
};

}  // namespace soda
