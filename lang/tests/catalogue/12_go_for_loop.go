// Go's `for` is not a mission statement: RepeatFor and RepeatWhile are.
package GoFor

var Drone1 Quadcopter

func INIT() {
	for i := 0; i < 4; i++ {
		Drone1.FlyByX(1)
	}
}
