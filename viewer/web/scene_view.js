// The 3-D view: one InstancedMesh per shape type (unit geometry, scaled per
// instance; capsules per length/radius ratio; convex hulls, compounds,
// triangle meshes and heightfields per body), bodies
// coloured by owning world or by sleep, statics in grey, territory borders
// as lines on the faces between cells of different owners. Bodies come and
// go with the frames (their ids): a body that comes takes a free instance of
// its shape's mesh (the mesh grows when full), one that goes is hidden and
// its instance freed.
import * as THREE from '/three/build/three.module.js';
import { OrbitControls } from '/three/examples/jsm/controls/OrbitControls.js';
import { ConvexBufferGeometry } from '/three/examples/jsm/geometries/ConvexGeometry.js';
import { BufferGeometryUtils } from '/three/examples/jsm/utils/BufferGeometryUtils.js';
import { ASLEEP_COLOUR, AWAKE_COLOUR, BACKGROUND_COLOUR, BORDER_COLOUR, STATIC_COLOUR, worldColour } from './palette.js';

// Most border segments drawn: beyond, a map is too fine to read as lines.
const MAX_BORDER_FACES = 200000;
// Static bodies larger than this (half extent, m) are left out of the
// camera's first framing.
const STATIC_FIT_LIMIT = 40;

// A body's mesh group key, its unit geometry maker and its instance scale.
function shapeKind(shape) {
  switch (shape.kind) {
    case 'compound':  // its own geometry: its children's, each at its pose
      return { key: null, scale: [1, 1, 1], make: () => compoundGeometry(shape.children) };
    case 'box': {
      const e = shape.half_extents;
      return { key: 'box', scale: [2 * e[0], 2 * e[1], 2 * e[2]], make: () => new THREE.BoxBufferGeometry(1, 1, 1) };
    }
    case 'sphere':
      return { key: 'sphere', scale: [shape.radius, shape.radius, shape.radius],
               make: () => new THREE.SphereBufferGeometry(1, 16, 12) };
    case 'cylinder': {
      const e = shape.half_extents;  // x = z = radius, y = half height
      return { key: 'cylinder', scale: [e[0], e[1], e[2]],
               make: () => new THREE.CylinderBufferGeometry(1, 1, 2, 20) };
    }
    case 'capsule': {
      const ratio = Math.round((shape.height / shape.radius) * 100) / 100;
      return { key: `capsule:${ratio}`, scale: [shape.radius, shape.radius, shape.radius],
               make: () => capsuleGeometry(ratio / 2) };
    }
    case 'triangle_mesh':  // its own geometry, as the scene gives it
      return { key: null, scale: [1, 1, 1], make: () => triangleMeshGeometry(shape.vertices, shape.indices) };
    case 'heightfield':
      return { key: null, scale: [1, 1, 1], make: () => heightfieldGeometry(shape) };
    default:  // convex hull: its own geometry
      return { key: null, scale: [1, 1, 1],
               make: () => new ConvexBufferGeometry(shape.points.map((p) => new THREE.Vector3(p[0], p[1], p[2]))) };
  }
}

// The children's geometries (unit ones scaled as their kind says, then
// placed at the child's pose) merged into one: positions and normals only,
// unindexed, as BufferGeometryUtils merges them.
function compoundGeometry(children) {
  const parts = children.map((child) => {
    const kind = shapeKind(child.shape);
    let g = kind.make();
    if (g.index) g = g.toNonIndexed();
    g.deleteAttribute('uv');
    if (!g.getAttribute('normal')) g.computeVertexNormals();
    const [x, y, z, w] = child.orientation;
    g.applyMatrix(new THREE.Matrix4().compose(new THREE.Vector3(...child.position), new THREE.Quaternion(x, y, z, w),
                                              new THREE.Vector3(...kind.scale)));
    return g;
  });
  return BufferGeometryUtils.mergeBufferGeometries(parts);
}

function triangleMeshGeometry(vertices, indices) {
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.Float32BufferAttribute(vertices, 3));
  g.setIndex(indices);
  g.computeVertexNormals();
  return g;
}

// Sample (i, j) at x = (i - (columns - 1) / 2) sx, z = (j - (rows - 1) / 2) sz,
// y = height sy, two triangles a quad (docs/scene-format.md).
function heightfieldGeometry(shape) {
  const { columns, rows, spacing, heights } = shape;
  const vertices = [];
  for (let j = 0; j < rows; ++j)
    for (let i = 0; i < columns; ++i)
      vertices.push((i - (columns - 1) / 2) * spacing[0], heights[j * columns + i] * spacing[1],
                    (j - (rows - 1) / 2) * spacing[2]);
  const indices = [];
  for (let j = 0; j + 1 < rows; ++j)
    for (let i = 0; i + 1 < columns; ++i) {
      const a = j * columns + i, b = a + 1, c = a + columns, d = c + 1;
      indices.push(a, c, b, b, c, d);
    }
  return triangleMeshGeometry(vertices, indices);
}

// A capsule of radius 1 whose cylinder part spans y in [-halfLength, halfLength].
function capsuleGeometry(halfLength) {
  const profile = [];
  const arc = 8;
  for (let i = 0; i <= arc; ++i) {
    const a = -Math.PI / 2 + (i / arc) * (Math.PI / 2);
    profile.push(new THREE.Vector2(Math.cos(a), Math.sin(a) - halfLength));
  }
  for (let i = 0; i <= arc; ++i) {
    const a = (i / arc) * (Math.PI / 2);
    profile.push(new THREE.Vector2(Math.cos(a), Math.sin(a) + halfLength));
  }
  return new THREE.LatheBufferGeometry(profile, 20);
}

// Instances a group starts with beyond the header's bodies of its shape,
// and the factor it grows by when bodies added during the run need more.
const SPARE_INSTANCES = 4;
const GROWTH = 2;

export class SceneView {
  constructor(container, header) {
    this.header = header;
    this.renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(window.devicePixelRatio || 1);
    this.renderer.setSize(container.clientWidth, container.clientHeight);
    this.renderer.setClearColor(BACKGROUND_COLOUR);
    container.appendChild(this.renderer.domElement);
    this.scene = new THREE.Scene();
    this.scene.add(new THREE.AmbientLight(0xffffff, 0.55));
    const sun = new THREE.DirectionalLight(0xffffff, 0.6);
    sun.position.set(0.4, 1, 0.3);
    this.scene.add(sun);
    this.camera = new THREE.PerspectiveCamera(45, container.clientWidth / container.clientHeight, 0.05, 5000);
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.addEventListener('change', () => this.render());
    window.addEventListener('resize', () => {
      this.camera.aspect = container.clientWidth / container.clientHeight;
      this.camera.updateProjectionMatrix();
      this.renderer.setSize(container.clientWidth, container.clientHeight);
      this.render();
    });
    this.buildBodies();
    this.fitCamera();
    this.borders = null;
    this.showBorders = true;
  }

  // Groups every body by shape type (one InstancedMesh each, with room for
  // the header's bodies and a few more); statics are placed once, dynamic
  // bodies get a slot (group, index) while a frame holds them.
  buildBodies() {
    this.matrix = new THREE.Matrix4();
    this.position = new THREE.Vector3();
    this.quaternion = new THREE.Quaternion();
    this.scaleVector = new THREE.Vector3();
    this.colour = new THREE.Color();
    this.hidden = new THREE.Matrix4().makeScale(0, 0, 0);
    this.groups = new Map();       // key -> {mesh, colours, capacity, used, free, make}
    this.described = new Map();    // dynamic body id -> its description (header's and added ones)
    this.slots = new Map();        // dynamic body id -> {group, index, scale}, the bodies drawn
    this.headerIds = [];           // the header's dynamic bodies, ascending id
    this.shownIds = null;          // the ids of the frame drawn last (null: none yet)
    const wanted = new Map();      // key -> {count: instances the header needs, make}
    const statics = [];
    for (const body of this.header.bodies) {
      const kind = shapeKind(body.shape);
      const key = this.groupKey(body, kind);
      if (!wanted.has(key)) wanted.set(key, { count: 0, make: kind.make });
      wanted.get(key).count += 1;
      if (body.static) statics.push({ body, kind, key });
      else {
        this.described.set(body.id, body);
        this.headerIds.push(body.id);
      }
    }
    for (const [key, { count, make }] of wanted) this.makeGroup(key, count + SPARE_INSTANCES, make);
    const grey = new THREE.Color(STATIC_COLOUR);
    for (const { body, kind, key } of statics) {
      const slot = this.takeSlot(key, kind);
      this.place(slot, body.position, body.orientation);
      slot.group.colours.set([grey.r, grey.g, grey.b], slot.index * 3);
    }
  }

  groupKey(body, kind) {
    return (body.static ? 'static:' : '') + (kind.key ?? `hull:${body.id}`);
  }

  // A new InstancedMesh for `key` with room for `capacity` instances, every
  // one hidden; an old one of that key (too small) is copied and replaced
  // (its geometry kept).
  makeGroup(key, capacity, make) {
    const old = this.groups.get(key);
    const geometry = old ? old.mesh.geometry : make();
    const group = old ?? { used: 0, free: [] };
    const colours = new Float32Array(capacity * 3);
    const mesh = new THREE.InstancedMesh(geometry, new THREE.MeshLambertMaterial({
      vertexColors: THREE.VertexColors }), capacity);
    for (let i = 0; i < capacity; ++i) this.hidden.toArray(mesh.instanceMatrix.array, i * 16);
    if (old) {
      mesh.instanceMatrix.array.set(old.mesh.instanceMatrix.array);
      colours.set(old.colours);
      this.scene.remove(old.mesh);
      old.mesh.material.dispose();
    }
    mesh.geometry.setAttribute('color', new THREE.InstancedBufferAttribute(colours, 3));
    mesh.frustumCulled = false;  // instances lie far from the unit geometry's bounds
    group.mesh = mesh;
    group.colours = colours;
    group.capacity = capacity;
    this.groups.set(key, group);
    this.scene.add(mesh);
    return group;
  }

  // A free instance of the group `key` (made, or grown, when needed).
  takeSlot(key, kind) {
    let group = this.groups.get(key);
    if (!group) group = this.makeGroup(key, 1 + SPARE_INSTANCES, kind.make);
    let index = group.free.pop();
    if (index === undefined) {
      if (group.used === group.capacity) group = this.makeGroup(key, group.capacity * GROWTH);
      index = group.used++;
    }
    return { group, index, scale: kind.scale };
  }

  // Descriptions of bodies a frame may hold that the header lacks (from the
  // server's /bodies).
  describe(bodies) {
    for (const body of bodies) if (!body.static) this.described.set(body.id, body);
  }

  // The ids of `ids` this view has no description of.
  undescribed(ids) {
    return ids ? Array.from(ids).filter((id) => !this.described.has(id)) : [];
  }

  // Whether body `id` is drawn now (tests).
  isDrawn(id) {
    return this.slots.has(id);
  }

  drawnCount() {
    return this.slots.size;
  }

  // Vertices of the geometry body `id` (static or dynamic) is drawn with
  // (tests); 0 for an unknown body.
  vertexCount(id) {
    const body = this.header.bodies.find((b) => b.id === id) ?? this.described.get(id);
    const group = body && this.groups.get(this.groupKey(body, shapeKind(body.shape)));
    return group ? group.mesh.geometry.getAttribute('position').count : 0;
  }

  place(slot, p, q) {
    this.matrix.compose(this.position.set(p[0], p[1], p[2]), this.quaternion.set(q[0], q[1], q[2], q[3]),
                        this.scaleVector.set(slot.scale[0], slot.scale[1], slot.scale[2]));
    this.matrix.toArray(slot.group.mesh.instanceMatrix.array, slot.index * 16);
  }

  // Looks at the dynamic bodies' initial box from above and aside (y up).
  fitCamera() {
    const box = new THREE.Box3();
    // Dynamic bodies' initial positions, and statics' centres unless they
    // are huge (a ground plate): walls and catch rows mark where bodies go.
    for (const b of this.header.bodies) {
      const e = b.shape.half_extents;
      const huge = b.static && (!e || Math.max(...e) > STATIC_FIT_LIMIT);
      if (!huge) box.expandByPoint(new THREE.Vector3(...b.position));
    }
    if (box.isEmpty()) box.set(new THREE.Vector3(-5, 0, -5), new THREE.Vector3(5, 5, 5));
    const centre = box.getCenter(new THREE.Vector3());
    const size = 1.25 * box.getSize(new THREE.Vector3()).length() + 2;
    this.camera.position.set(centre.x + 0.75 * size, centre.y + 0.55 * size, centre.z + 0.9 * size);
    this.controls.target.copy(centre);
    this.camera.lookAt(centre);
    this.controls.update();
  }

  // Makes the drawn bodies those of `ids` (null: the header's): a body that
  // came gets an instance, one that went gives its instance back (hidden).
  // A body nobody described (the server could not) is left out.
  setBodies(ids) {
    const list = ids ?? this.headerIds;
    if (this.shownIds === list || (ids === null && this.shownIds === this.headerIds)) return;
    const wanted = new Set(list);
    for (const [id, slot] of this.slots) {
      if (wanted.has(id)) continue;
      this.hidden.toArray(slot.group.mesh.instanceMatrix.array, slot.index * 16);
      slot.group.free.push(slot.index);
      this.slots.delete(id);
    }
    for (const id of list) {
      if (this.slots.has(id)) continue;
      const body = this.described.get(id);
      if (!body) continue;
      const kind = shapeKind(body.shape);
      this.slots.set(id, this.takeSlot(this.groupKey(body, kind), kind));
    }
    this.shownIds = list;
  }

  // Poses and colours of one frame; colourMode 'world' or 'sleep'.
  update(frame, colourMode) {
    this.setBodies(frame.ids);
    const ids = frame.ids ?? this.headerIds;
    const p = frame.position;
    const q = frame.orientation;
    for (let i = 0; i < ids.length; ++i) {
      const slot = this.slots.get(ids[i]);
      if (!slot) continue;  // not described: not drawn
      const o = 3 * i;
      const r = 4 * i;
      this.matrix.compose(this.position.set(p[o], p[o + 1], p[o + 2]),
                          this.quaternion.set(q[r], q[r + 1], q[r + 2], q[r + 3]),
                          this.scaleVector.set(slot.scale[0], slot.scale[1], slot.scale[2]));
      this.matrix.toArray(slot.group.mesh.instanceMatrix.array, slot.index * 16);
      const hex = colourMode === 'sleep' ? (frame.sleeping[i] ? ASLEEP_COLOUR : AWAKE_COLOUR)
                                         : worldColour(frame.owner[i]);
      this.colour.setHex(hex);
      slot.group.colours[slot.index * 3] = this.colour.r;
      slot.group.colours[slot.index * 3 + 1] = this.colour.g;
      slot.group.colours[slot.index * 3 + 2] = this.colour.b;
    }
    for (const group of this.groups.values()) {
      group.mesh.instanceMatrix.needsUpdate = true;
      group.mesh.geometry.attributes.color.needsUpdate = true;
    }
    if (frame.cellOwner.length > 0) this.setBorders(frame.cellOwner);
  }

  // Lines around every face shared by two box cells of different owners.
  setBorders(cellOwner) {
    if (this.borders) {
      this.scene.remove(this.borders);
      this.borders.geometry.dispose();
    }
    const { lo, hi } = this.header.box;
    const ext = [hi[0] - lo[0] + 1, hi[1] - lo[1] + 1, hi[2] - lo[2] + 1];
    if (cellOwner.length !== ext[0] * ext[1] * ext[2]) return;
    const size = this.header.grid.cell_size;
    const origin = this.header.grid.origin;
    const at = (x, y, z) => cellOwner[(x * ext[1] + y) * ext[2] + z];
    const points = [];
    let faces = 0;
    const corner = (x, y, z) => [origin[0] + (lo[0] + x) * size, origin[1] + (lo[1] + y) * size,
                                 origin[2] + (lo[2] + z) * size];
    const face = (axis, x, y, z) => {  // the face at the upper side of cell (x, y, z) along axis
      const c = [x, y, z];
      c[axis] += 1;
      const u = (axis + 1) % 3;
      const v = (axis + 2) % 3;
      const quad = [[0, 0], [1, 0], [1, 1], [0, 1]].map(([a, b]) => {
        const k = c.slice();
        k[u] += a;
        k[v] += b;
        return corner(k[0], k[1], k[2]);
      });
      for (let e = 0; e < 4; ++e) points.push(...quad[e], ...quad[(e + 1) % 4]);
    };
    for (let x = 0; x < ext[0] && faces < MAX_BORDER_FACES; ++x)
      for (let y = 0; y < ext[1]; ++y)
        for (let z = 0; z < ext[2]; ++z) {
          const o = at(x, y, z);
          if (x + 1 < ext[0] && at(x + 1, y, z) !== o) { face(0, x, y, z); ++faces; }
          if (y + 1 < ext[1] && at(x, y + 1, z) !== o) { face(1, x, y, z); ++faces; }
          if (z + 1 < ext[2] && at(x, y, z + 1) !== o) { face(2, x, y, z); ++faces; }
        }
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.Float32BufferAttribute(points, 3));
    this.borders = new THREE.LineSegments(geometry, new THREE.LineBasicMaterial({
      color: BORDER_COLOUR, transparent: true, opacity: 0.18, depthWrite: false }));
    this.borders.visible = this.showBorders;
    this.borders.userData.faces = faces;
    this.scene.add(this.borders);
  }

  setBordersVisible(visible) {
    this.showBorders = visible;
    if (this.borders) this.borders.visible = visible;
    this.render();
  }

  render() {
    this.renderer.render(this.scene, this.camera);
  }
}
