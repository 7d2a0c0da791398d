// A name in an argument that is neither a constant nor a parameter.
package UnknownConst

const Side = 2.5

var Drone1 Quadcopter

func INIT() {
	Drone1.FlyByX(Sid)
	Drone1.FlyByY(Height)
}
