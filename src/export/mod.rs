//! Engine formats (DESIGN.md pipeline, last box): [`spine`] writes a puppet and poses of it as a
//! Spine 4.2 skeleton — JSON, texture atlas and page — which Spine's runtimes play in Unity,
//! Godot, Unreal, Phaser, PixiJS and the rest. (Frame-based outputs — PNG sequences, sprite
//! sheets with atlases, APNG, GIF — are written by `render::animation`.)

mod region_page;
pub mod spine;
