// The viewer's fixed colours (docs/viewer.md, "Colours"). World w is drawn in
// WORLD_COLOURS[w % 12]: twelve saturated colours of well separated hues, so
// that neighbouring territories stay apart (and the browser tests can tell
// them apart by chromaticity under lighting).
export const WORLD_COLOURS = [
  0xe6194b, // 0 red
  0x3cb44b, // 1 green
  0x4363d8, // 2 blue
  0xf58231, // 3 orange
  0x911eb4, // 4 purple
  0x42d4f4, // 5 cyan
  0xf032e6, // 6 magenta
  0xffe119, // 7 yellow
  0x469990, // 8 teal
  0x000075, // 9 navy
  0xaaffc3, // 10 mint
  0x800000, // 11 maroon
];
export const AWAKE_COLOUR = 0xffb000;   // by sleep: awake bodies
export const ASLEEP_COLOUR = 0x5a6b8c;  // by sleep: sleeping bodies
export const STATIC_COLOUR = 0x8a8d93;  // static bodies (ground, walls)
export const BACKGROUND_COLOUR = 0x1b1e24;
export const BORDER_COLOUR = 0xffffff;  // territory borders (drawn translucent)

export function worldColour(world) {
  return WORLD_COLOURS[world % WORLD_COLOURS.length];
}

export function cssColour(hex) {
  return '#' + hex.toString(16).padStart(6, '0');
}
