// The 3-D view: one InstancedMesh per shape type (unit geometry, scaled per
// instance; capsules per length/radius ratio, convex hulls per body), bodies
// coloured by owning world or by sleep, statics in grey, territory borders
// as lines on the faces between cells of different owners.
import * as THREE from '/three/build/three.module.js';
import { OrbitControls } from '/three/examples/jsm/controls/OrbitControls.js';
import { ConvexBufferGeometry } from '/three/examples/jsm/geometries/ConvexGeometry.js';
import { ASLEEP_COLOUR, AWAKE_COLOUR, BACKGROUND_COLOUR, BORDER_COLOUR, STATIC_COLOUR, worldColour } from './palette.js';

// Most border segments drawn: beyond, a map is too fine to read as lines.
const MAX_BORDER_FACES = 200000;
// Static bodies larger than this (half extent, m) are left out of the
// camera's first framing.
const STATIC_FIT_LIMIT = 40;

// A body's mesh group key, its unit geometry maker and its instance scale.
function shapeKind(shape) {
  switch (shape.kind) {
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
    default:  // convex hull: its own geometry
      return { key: null, scale: [1, 1, 1],
               make: () => new ConvexBufferGeometry(shape.points.map((p) => new THREE.Vector3(p[0], p[1], p[2]))) };
  }
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

  // Groups every body by shape type; dynamic ones get a slot (mesh, index).
  buildBodies() {
    this.matrix = new THREE.Matrix4();
    this.position = new THREE.Vector3();
    this.quaternion = new THREE.Quaternion();
    this.scaleVector = new THREE.Vector3();
    this.colour = new THREE.Color();
    const groups = new Map();
    const slots = [];  // per dynamic body, in header order: {group, index, scale}
    const statics = [];
    this.header.bodies.forEach((body) => {
      const kind = shapeKind(body.shape);
      const key = (body.static ? 'static:' : '') + (kind.key ?? `hull:${body.id}`);
      if (!groups.has(key)) groups.set(key, { make: kind.make, count: 0, isStatic: body.static });
      const group = groups.get(key);
      const slot = { group, index: group.count++, scale: kind.scale };
      if (body.static) statics.push({ slot, body }); else slots.push(slot);
    });
    for (const group of groups.values()) {
      const geometry = group.make();
      const colours = new Float32Array(group.count * 3);
      geometry.setAttribute('color', new THREE.InstancedBufferAttribute(colours, 3));
      const material = new THREE.MeshLambertMaterial({ vertexColors: THREE.VertexColors });
      group.mesh = new THREE.InstancedMesh(geometry, material, group.count);
      group.mesh.frustumCulled = false;  // instances lie far from the unit geometry's bounds
      group.colours = colours;
      this.scene.add(group.mesh);
    }
    const grey = new THREE.Color(STATIC_COLOUR);
    for (const { slot, body } of statics) {
      this.place(slot, body.position, body.orientation);
      slot.group.colours.set([grey.r, grey.g, grey.b], slot.index * 3);
    }
    this.groups = [...groups.values()];
    this.slots = slots;
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

  // Poses and colours of one frame; colourMode 'world' or 'sleep'.
  update(frame, colourMode) {
    const p = frame.position;
    const q = frame.orientation;
    for (let i = 0; i < this.slots.length; ++i) {
      const slot = this.slots[i];
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
    for (const group of this.groups) {
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
